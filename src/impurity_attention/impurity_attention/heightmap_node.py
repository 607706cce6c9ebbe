"""Heightmap node: camera colour + aligned depth + camera_info -> /heightmap (orthographic colour and
height maps of the workspace in base_link).

Thin shell around impurity_attention.core.heightmap: it converts messages, pairs colour and depth by
stamp, and drops bad frames with one rate-limited log line each (never raises out of a callback).
The camera pose in base_link is a parameter: a real cell sets it from its hand-eye calibration.
"""

from dataclasses import dataclass

import numpy as np
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image

from impurity_attention.core.colour_adaptation import LabStatistics, reinhard_transfer
from impurity_attention.core.heightmap import (
    DEPTH_ENCODINGS,
    DepthFormatError,
    ProjectorCache,
    depth_to_meters,
    pose_matrix,
)
from impurity_attention.core.sync import StampPairer
from impurity_common import cell, names
from impurity_common.conversions import ImageFormatError, image_to_numpy, numpy_to_image, time_to_ns
from impurity_common.grid import MAX_HEIGHT, HeightmapGrid
from impurity_common.node_main import spin_node
from impurity_common.parameters import InvalidParameter, declare_parameters, increasing, nonzero_norm, param
from impurity_interfaces.msg import Heightmap

COLOR_ENCODINGS = ("rgb8", "bgr8")
# Lab statistics of the seen cells of sim-rendered heightmaps (70 tuning scenes): the reference of the
# optional sim-to-real transfer. Re-measure with `scripts/calibrate_attention.py lab-reference` when
# the sim's look changes.
SIM_LAB_MEAN = (60.21, 1.36, -8.57)
SIM_LAB_STD = (9.35, 5.76, 19.01)


@dataclass(frozen=True)
class HeightmapParameters:
    """Every parameter of the node (bringup/config/cell.yaml, section heightmap)."""

    camera_position: tuple[float, ...] = param(
        cell.CAMERA_POSITION, "Camera optical frame origin in base_link (m): [x, y, z] (from hand-eye "
        "calibration)", length=3, low=-5.0, high=5.0)
    camera_orientation: tuple[float, ...] = param(
        cell.CAMERA_ORIENTATION, "Camera optical frame orientation in base_link: quaternion [x, y, z, w]",
        length=4, check=nonzero_norm)
    workspace_x: tuple[float, ...] = param(cell.WORKSPACE_X, "[x_min, x_max] in base_link (m)",
                                           length=2, low=-5.0, high=5.0, check=increasing)
    workspace_y: tuple[float, ...] = param(cell.WORKSPACE_Y, "[y_min, y_max] in base_link (m)",
                                           length=2, low=-5.0, high=5.0, check=increasing)
    resolution: float = param(cell.HEIGHTMAP_RESOLUTION, "Heightmap cell size (m)", low=0.0005, high=0.05)
    table_z: float = param(cell.TABLE_Z, "Table top height in base_link (m)", low=-5.0, high=5.0)
    max_height: float = param(MAX_HEIGHT, "Points higher than this above the table are dropped (arm, "
                              "gripper, noise) (m)", low=0.001, high=5.0)
    sync_tolerance: float = param(0.01, "Largest stamp difference (s) for a colour and a depth frame to pair",
                                  low=0.0, high=1.0)
    colour_adaptation: bool = param(False, "Reinhard Lab transfer of heightmap colours to the sim reference "
                                    "statistics (real cameras)")
    colour_reference_mean: tuple[float, ...] = param(SIM_LAB_MEAN, "Reference Lab mean [L, a, b] for colour "
                                                     "adaptation", length=3, low=-128.0, high=128.0)
    colour_reference_std: tuple[float, ...] = param(SIM_LAB_STD, "Reference Lab standard deviation [L, a, b] "
                                                    "for colour adaptation", length=3, low=0.001, high=128.0)
    log_throttle: float = param(5.0, "s between repeated warnings about bad frames", low=0.0, high=3600.0)

    def __post_init__(self):
        extent = min(self.workspace_x[1] - self.workspace_x[0], self.workspace_y[1] - self.workspace_y[0])
        if self.resolution > extent:
            raise InvalidParameter("resolution", f"is larger than the workspace ({extent:g} m across)")

    def grid(self) -> HeightmapGrid:
        (x_min, x_max), (y_min, y_max) = self.workspace_x, self.workspace_y
        return HeightmapGrid(x_min=x_min, x_max=x_max, y_min=y_min, y_max=y_max, resolution=self.resolution,
                             table_z=self.table_z, max_height=self.max_height)


class HeightmapNode(Node):
    def __init__(self):
        super().__init__("heightmap")
        params = self.params = declare_parameters(self, HeightmapParameters)

        self._grid = params.grid()
        self._camera_pose = pose_matrix(params.camera_position, params.camera_orientation)
        self._pairer = StampPairer(tolerance_ns=int(params.sync_tolerance * 1e9))
        self._projectors = ProjectorCache()
        self._camera_info: CameraInfo | None = None
        self._reference = LabStatistics(params.colour_reference_mean, params.colour_reference_std)

        sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                            history=qos_profile_sensor_data.history)
        self.create_subscription(Image, names.COLOR_TOPIC, self._on_color, sensor)
        self.create_subscription(Image, names.DEPTH_TOPIC, self._on_depth, sensor)
        self.create_subscription(CameraInfo, names.CAMERA_INFO_TOPIC, self._on_info, sensor)
        self._publisher = self.create_publisher(
            Heightmap, names.HEIGHTMAP_TOPIC, QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE))
        grid = self._grid
        self.get_logger().info(
            f"ready: {grid.rows}x{grid.cols} cells of {grid.resolution * 1000:.1f} mm over "
            f"x {grid.x_min:.3f}..{grid.x_max:.3f}, y {grid.y_min:.3f}..{grid.y_max:.3f}; "
            f"camera at {list(params.camera_position)}")

    def _drop(self, reason: str) -> None:
        self.get_logger().warning(f"frame dropped: {reason}",
                                  throttle_duration_sec=self.params.log_throttle)

    def _on_info(self, msg: CameraInfo) -> None:
        if msg.k[0] <= 0 or msg.k[4] <= 0 or msg.width == 0 or msg.height == 0:
            self._drop(f"camera_info with unusable intrinsics k={list(msg.k)} size {msg.width}x{msg.height}")
            return
        self._camera_info = msg

    def _on_color(self, msg: Image) -> None:
        pair = self._pairer.add_color(time_to_ns(msg.header.stamp), msg)
        if pair is not None:
            self._process(*pair)

    def _on_depth(self, msg: Image) -> None:
        pair = self._pairer.add_depth(time_to_ns(msg.header.stamp), msg)
        if pair is not None:
            self._process(*pair)

    def _process(self, color_msg: Image, depth_msg: Image) -> None:
        try:
            heightmap = self._make_heightmap(color_msg, depth_msg)
        except (ImageFormatError, DepthFormatError, ValueError) as error:
            self._drop(str(error))
            return
        if heightmap is not None:
            self._publisher.publish(heightmap)

    def _make_heightmap(self, color_msg: Image, depth_msg: Image) -> Heightmap | None:
        info = self._camera_info
        if info is None:
            self._drop(f"no camera_info on {names.CAMERA_INFO_TOPIC} yet")
            return None
        color = image_to_numpy(color_msg, COLOR_ENCODINGS)
        if color_msg.encoding == "bgr8":
            color = np.ascontiguousarray(color[..., ::-1])
        depth = depth_to_meters(image_to_numpy(depth_msg, DEPTH_ENCODINGS), depth_msg.encoding)
        if color.shape[:2] != depth.shape:
            raise ValueError(f"colour {color.shape[1]}x{color.shape[0]} and depth "
                             f"{depth.shape[1]}x{depth.shape[0]} differ (depth must be aligned to colour)")
        if (info.height, info.width) != depth.shape:
            raise ValueError(f"camera_info is {info.width}x{info.height}, images are "
                             f"{depth.shape[1]}x{depth.shape[0]}")
        intrinsics = np.array(info.k).reshape(3, 3)
        projector = self._projectors.get(intrinsics, self._camera_pose, depth.shape, self._grid)
        maps = projector.project(color, depth)
        color_map = maps.color
        if self.params.colour_adaptation:
            color_map = reinhard_transfer(color_map, self._reference, valid=maps.seen)
        msg = Heightmap()
        msg.header.stamp = color_msg.header.stamp
        msg.header.frame_id = names.BASE_FRAME
        msg.resolution = float(self._grid.resolution)
        msg.origin.x, msg.origin.y, msg.origin.z = self._grid.x_min, self._grid.y_min, self._grid.table_z
        msg.color = numpy_to_image(color_map, "rgb8", msg.header)
        msg.height = numpy_to_image(maps.height, "32FC1", msg.header)
        return msg


def main(args=None):
    spin_node(HeightmapNode, args=args)


if __name__ == "__main__":
    main()
