"""Heightmap node: camera colour + aligned depth + camera_info -> /heightmap (orthographic colour and
height maps of the workspace in base_link).

Thin shell around impurity_attention.core.heightmap: it converts messages, pairs colour and depth by
stamp, and drops bad frames with one rate-limited log line each (never raises out of a callback). A frame
that cannot make a heightmap - a bad image, depth that does not fit the table and the camera pose (units,
too few depths, the table fitted through the depth tilted or offset from table_z) - is dropped with its
reason also sent on /heightmap/dropped (std_msgs/String), on which the episode node ends an episode.
Pixels with colour and no depth reach the heightmap as height unknown (NaN; core.unknown_height).
The camera pose in base_link is a parameter: a real cell sets it from its hand-eye calibration.

What a real camera does differently from the simulated one is said in the log, each with its cause
and the parameter to change: frames that go unpaired (rate-limited, with the measured stamp offset:
`sync_tolerance`, or `depth_offset` when it is near one frame period), depth that does not fit the table and
the camera pose (rate-limited: `depth_scale`, `camera_position`, `camera_orientation`), object-sized regions
of colour without depth and brightness jumping between frames of a still scene (rate-limited, naming the
camera's settings), pixels coarser than the cells (once: the gaps between
samples are filled), frames stamped on another clock than the node's (once: `use_sim_time`, the
driver's timestamp setting), a camera topic with no message for `frame_timeout` s (rate-limited, naming the
topics: the camera driver is not running or publishes other names). With `use_sim_time:=true` and no /clock,
frames are dropped and that is said once (impurity_common.sim_time).
"""

import time
from dataclasses import dataclass

import numpy as np
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import String

from impurity_attention.core.colour_adaptation import LabStatistics, reinhard_transfer
from impurity_attention.core.heightmap import (
    DEPTH_ENCODINGS,
    DepthFormatError,
    HeightmapParams,
    ProjectorCache,
    brightness_jump,
    depth_problem,
    depth_sample,
    depth_to_meters,
    exposure_problem,
    mean_brightness,
    still_scene,
)
from impurity_attention.core.sync import StampPairer, StreamWatch, unpaired_warning
from impurity_attention.core.unknown_height import unknown_height_warning, unknown_regions
from impurity_common import names
from impurity_common.conversions import (
    RGB_ENCODINGS,
    ImageFormatError,
    image_to_numpy,
    image_to_rgb,
    numpy_to_image,
    time_to_ns,
)
from impurity_common.diagnostics import OK, WARN, Diagnostics, RateMeter, Status
from impurity_common.node_main import spin_node
from impurity_common.parameters import declare_parameters, param
from impurity_common.sim_time import StoppedClockGate
from impurity_interfaces.msg import Heightmap

COLOR_ENCODINGS = tuple(RGB_ENCODINGS)  # rgb8, bgr8, rgba8, bgra8: read as RGB, alpha dropped
# Frames stamped further than this from the node's clock are on another clock (warned once).
STAMP_OFFSET_WARNING = 1.0  # s


@dataclass(frozen=True)
class HeightmapNodeParameters(HeightmapParams):
    """Every parameter of the node (bringup/config/cell.yaml, section heightmap): the heightmap's own
    (core.heightmap.HeightmapParams) and the node's logging settings."""

    log_throttle: float = param(5.0, "s between repeated warnings about bad frames", low=0.0, high=3600.0)
    frame_timeout: float = param(5.0, "s without a message on a camera topic (colour, depth, camera_info) "
                                 "before the node warns, every frame_timeout s while it lasts; 0 = never",
                                 low=0.0, high=3600.0)


class HeightmapNode(Node):
    def __init__(self):
        super().__init__("heightmap")
        params = self.params = declare_parameters(self, HeightmapNodeParameters)

        self._grid = params.grid()
        self._camera_pose = params.camera_pose()
        self._pairer = StampPairer(tolerance_ns=params.pairing_tolerance_ns())
        self._warned_clock = False
        self._stopped_clock = StoppedClockGate(self)
        self._warned_footprint = None  # the projector the footprint warning was given for
        self._brightness = None  # (mean brightness, depth_sample) of the last frame
        self._projectors = ProjectorCache()
        self._camera_info: CameraInfo | None = None
        self._reference = LabStatistics(params.colour_reference_mean, params.colour_reference_std)

        sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                            history=qos_profile_sensor_data.history)
        self.create_subscription(Image, names.COLOR_TOPIC, self._on_color, sensor)
        self.create_subscription(Image, names.DEPTH_TOPIC, self._on_depth, sensor)
        self.create_subscription(CameraInfo, names.CAMERA_INFO_TOPIC, self._on_info, sensor)
        self._watch = StreamWatch((names.COLOR_TOPIC, names.DEPTH_TOPIC, names.CAMERA_INFO_TOPIC),
                                  time.monotonic())
        if params.frame_timeout > 0:
            self.create_timer(params.frame_timeout, self._check_streams)
        self._publisher = self.create_publisher(
            Heightmap, names.HEIGHTMAP_TOPIC, QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE))
        self._frame_rate, self._heightmap_rate = RateMeter(), RateMeter()
        self.diagnostics = Diagnostics(self, self._status)
        self._dropped = self.create_publisher(String, names.HEIGHTMAP_DROPPED_TOPIC, 10)
        grid = self._grid
        self.get_logger().info(
            f"ready: {grid.rows}x{grid.cols} cells of {grid.resolution * 1000:.1f} mm over "
            f"x {grid.x_min:.3f}..{grid.x_max:.3f}, y {grid.y_min:.3f}..{grid.y_max:.3f}; "
            f"camera at {list(params.camera_position)}")

    def _status(self) -> Status:
        """Camera frame rate (colour frames received), heightmap rate, pairs dropped; WARN while a camera
        topic is silent for frame_timeout s (0: never)."""
        frames, heightmaps = self._frame_rate, self._heightmap_rate
        values = {"frame rate (Hz)": frames.rate(), "heightmap rate (Hz)": heightmaps.rate(),
                  "frames received": frames.count, "heightmaps published": heightmaps.count,
                  "pairs dropped": self._pairer.dropped}
        silent = self._watch.silent(time.monotonic(), self.params.frame_timeout)
        if silent:
            return Status(WARN, "no camera messages on " + ", ".join(silent), values)
        return Status(OK, f"{values['heightmap rate (Hz)']:.1f} heightmaps/s", values)

    def _drop(self, reason: str) -> None:
        self.get_logger().warning(f"frame dropped: {reason}",
                                  throttle_duration_sec=self.params.log_throttle)

    def _drop_unusable(self, reason: str) -> None:
        """Drop a frame that cannot make a heightmap, and say why on /heightmap/dropped (the episode ends
        on it, naming the reason)."""
        self._drop(reason)
        self._dropped.publish(String(data=reason))

    def _check_streams(self) -> None:
        silent = self._watch.silent(time.monotonic(), self.params.frame_timeout)
        if silent:
            topics = ", ".join(f"{topic} ({seconds:.0f} s)" for topic, seconds in silent.items())
            self.get_logger().warning(
                f"no camera messages on {topics}: is the camera driver running, and does it publish these "
                "names (realsense-ros: camera_namespace / camera_name 'camera', align_depth.enable true for "
                "the aligned depth; or remap them)? No heightmap is published without all three")

    def _on_info(self, msg: CameraInfo) -> None:
        self._watch.seen(names.CAMERA_INFO_TOPIC, time.monotonic())
        if msg.k[0] <= 0 or msg.k[4] <= 0 or msg.width == 0 or msg.height == 0:
            self._drop(f"camera_info with unusable intrinsics k={list(msg.k)} size {msg.width}x{msg.height}")
            return
        self._camera_info = msg

    def _on_color(self, msg: Image) -> None:
        self._watch.seen(names.COLOR_TOPIC, time.monotonic())
        self._frame_rate.tick()
        stamp = time_to_ns(msg.header.stamp)
        self._check_clock(stamp)
        self._pairs(self._pairer.add_color(stamp, msg))

    def _on_depth(self, msg: Image) -> None:
        self._watch.seen(names.DEPTH_TOPIC, time.monotonic())
        stamp = time_to_ns(msg.header.stamp) - int(round(self.params.depth_offset * 1e9))
        self._pairs(self._pairer.add_depth(stamp, msg))

    def _pairs(self, pairs: list) -> None:
        """Process the pairs a frame completed; say why frames went unpaired."""
        unpaired = self._pairer.take_unpaired()
        if unpaired:
            self.get_logger().warning(
                unpaired_warning(unpaired, self._pairer, self.params.sync_tolerance, self.params.depth_offset,
                                 names.COLOR_TOPIC, names.DEPTH_TOPIC),
                throttle_duration_sec=self.params.log_throttle)
        for color_msg, depth_msg in pairs:
            self._process(color_msg, depth_msg)

    def _check_clock(self, stamp_ns: int) -> None:
        """Warn once when frames are stamped on another clock than this node's."""
        if self._warned_clock:
            return
        now_ns = self.get_clock().now().nanoseconds
        if now_ns == 0:  # use_sim_time and no /clock yet: nothing to compare with
            return
        offset = (stamp_ns - now_ns) / 1e9
        if abs(offset) <= STAMP_OFFSET_WARNING:
            return
        self._warned_clock = True
        self.get_logger().warning(
            f"camera frames are stamped {offset:+.1f} s from this node's clock (frame "
            f"{stamp_ns / 1e9:.3f} s, clock {now_ns / 1e9:.3f} s): the camera stamps on its own clock, and "
            "every check of an input's age downstream (the policy's max_age, the episode's waits) will "
            "misjudge it. Put the camera and the nodes on one clock: the driver's timestamp setting "
            "(realsense-ros: global_time_enabled:=true), or use_sim_time:=true for every node when a /clock "
            "is published (bag_replay -p clock:=true, simulation). (Said once.)")

    def _process(self, color_msg: Image, depth_msg: Image) -> None:
        if self._stopped_clock.stopped():
            return
        try:
            heightmap = self._make_heightmap(color_msg, depth_msg)
        except (ImageFormatError, DepthFormatError, ValueError) as error:
            self._drop_unusable(str(error))
            return
        if heightmap is not None:
            self._publisher.publish(heightmap)
            self._heightmap_rate.tick()

    def _make_heightmap(self, color_msg: Image, depth_msg: Image) -> Heightmap | None:
        info = self._camera_info
        if info is None:
            self._drop(f"no camera_info on {names.CAMERA_INFO_TOPIC} yet")
            return None
        color = image_to_rgb(color_msg, COLOR_ENCODINGS)
        depth = depth_to_meters(image_to_numpy(depth_msg, DEPTH_ENCODINGS), depth_msg.encoding,
                                self.params.depth_scale)
        if color.shape[:2] != depth.shape:
            raise ValueError(f"colour {color.shape[1]}x{color.shape[0]} and depth "
                             f"{depth.shape[1]}x{depth.shape[0]} differ (depth must be aligned to colour)")
        if (info.height, info.width) != depth.shape:
            raise ValueError(f"camera_info is {info.width}x{info.height}, images are "
                             f"{depth.shape[1]}x{depth.shape[0]}")
        intrinsics = np.array(info.k).reshape(3, 3)
        projector = self._projectors.get(intrinsics, self._camera_pose, depth.shape, self._grid)
        self._check_footprint(projector)
        self._check_brightness(color, depth)
        problem = depth_problem(projector.check_depth(depth), depth_msg.encoding, self.params.depth_scale)
        if problem is not None:
            self._drop_unusable(f"depth does not fit the table: {problem}")
            return None
        maps = projector.project(color, depth)
        exposure = exposure_problem(maps.color, maps.height)
        if exposure is not None:
            self.get_logger().warning(f"colour badly exposed: {exposure}",
                                      throttle_duration_sec=self.params.log_throttle)
        holes = unknown_height_warning(unknown_regions(maps.color, maps.height, maps.unknown),
                                       self._grid.resolution)
        if holes is not None:
            self.get_logger().warning(f"colour without depth: {holes}",
                                      throttle_duration_sec=self.params.log_throttle)
        color_map = maps.color
        if self.params.colour_adaptation:
            color_map = reinhard_transfer(color_map, self._reference, valid=maps.known | maps.unknown)
        msg = Heightmap()
        msg.header.stamp = color_msg.header.stamp
        msg.header.frame_id = names.BASE_FRAME
        msg.resolution = float(self._grid.resolution)
        msg.origin.x, msg.origin.y, msg.origin.z = self._grid.x_min, self._grid.y_min, self._grid.table_z
        msg.color = numpy_to_image(color_map, "rgb8", msg.header)
        msg.height = numpy_to_image(maps.height_or_unknown(), "32FC1", msg.header)
        return msg

    def _check_brightness(self, color, depth) -> None:
        """Warn (throttled) when the mean brightness jumps between consecutive frames of a still scene (auto
        exposure, flicker)."""
        brightness, sample = mean_brightness(color), depth_sample(depth)
        previous, self._brightness = self._brightness, (brightness, sample)
        if previous is None or not still_scene(previous[1], sample):
            return
        jump = brightness_jump(previous[0], brightness)
        if jump is not None:
            self.get_logger().warning(f"colour brightness unsteady: {jump}",
                                      throttle_duration_sec=self.params.log_throttle)

    def _check_footprint(self, projector) -> None:
        """Warn once per camera geometry when a pixel covers more of the table than a cell."""
        if projector is self._warned_footprint or not projector.footprint > self._grid.resolution:
            return
        self._warned_footprint = projector
        resolution = self._grid.resolution
        self.get_logger().warning(
            f"camera pixels cover up to {projector.footprint * 1000:.2f} mm of the table, more than the "
            f"{resolution * 1000:.1f} mm cells: cells between samples are filled from their neighbours "
            f"(gaps up to {projector.gap_reach} cell(s)). To see every cell, mount the camera lower, use a "
            f"higher camera resolution, or set resolution to {projector.footprint:.4f} m or more.")


def main(args=None):
    spin_node(HeightmapNode, args=args)


if __name__ == "__main__":
    main()
