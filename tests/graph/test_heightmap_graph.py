"""Graph tests: heightmap_node (a real process) fed by cameras unlike the simulated one:
colour and depth stamped apart, depth in 0.1 mm, frames stamped on the camera's own clock, four-channel
colour, pixels coarser than the cells. Each behaviour is seen on /heightmap or in the node's log."""

import dataclasses

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import String

from impurity_attention.core.synthetic import overhead_camera, random_boxes, render_boxes
from impurity_common import names
from impurity_common.conversions import image_to_numpy, ns_to_time, numpy_to_image, time_to_ns
from impurity_common.grid import HeightmapGrid
from impurity_interfaces.action import RunEpisode
from impurity_interfaces.msg import Heightmap
from ros_harness import ActionHelper, TopicRecorder, ros_args, spin_until, wait_for_subscribers

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
PERIOD_15HZ = 1_000_000_000 // 15
WAIT = 60.0  # s for any one thing to show up
GRID = HeightmapGrid()


def colour_bytes(rgb: np.ndarray, encoding: str) -> np.ndarray:
    alpha = np.full(rgb.shape[:2] + (1,), 255, np.uint8)
    return {"rgb8": rgb, "bgr8": rgb[..., ::-1], "rgba8": np.concatenate([rgb, alpha], axis=2),
            "bgra8": np.concatenate([rgb[..., ::-1], alpha], axis=2)}[encoding]


class StreamingCamera:
    """Publishes one synthetic scene as a 15 Hz stream (stamps a period apart, sent as often) until
    `frames` were sent: colour stamped t, depth stamped t + depth_offset_ns, camera_info; with `flicker`,
    every other colour frame is that much brighter (x 1 + flicker)."""

    def __init__(self, node, frame, first_stamp_ns: int, frames: int = 1000, depth_offset_ns: int = 0,
                 color_encoding: str = "rgb8", depth_units: float | None = None, flicker: float = 0.0):
        self.node, self.frames, self.sent = node, frames, []
        brighter = np.clip(frame.color * (1.0 + flicker), 0, 255).astype(np.uint8)
        self.colors = [numpy_to_image(colour_bytes(rgb, color_encoding), color_encoding)
                       for rgb in ((frame.color, brighter) if flicker else (frame.color,))]
        self.first_stamp_ns, self.depth_offset_ns = first_stamp_ns, depth_offset_ns
        self.color = self.colors[0]
        self.depth = (numpy_to_image(frame.depth, "32FC1") if depth_units is None else
                      numpy_to_image(np.round(frame.depth / depth_units).astype(np.uint16), "16UC1"))
        self.info = CameraInfo(width=frame.color.shape[1], height=frame.color.shape[0])
        self.info.k = [float(v) for v in frame.intrinsics.reshape(-1)]
        for msg in (self.color, self.depth, self.info):
            msg.header.frame_id = names.CAMERA_OPTICAL_FRAME
        self.color_pub = node.create_publisher(Image, names.COLOR_TOPIC, RELIABLE)
        self.depth_pub = node.create_publisher(Image, names.DEPTH_TOPIC, RELIABLE)
        self.info_pub = node.create_publisher(CameraInfo, names.CAMERA_INFO_TOPIC, RELIABLE)
        self.timer = None

    def start(self, processes):
        for publisher in (self.color_pub, self.depth_pub, self.info_pub):
            wait_for_subscribers(self.node, publisher, 1, WAIT, processes)
        self.timer = self.node.create_timer(PERIOD_15HZ / 1e9, self._publish)

    def _publish(self):
        if len(self.sent) >= self.frames:
            return
        stamp = self.first_stamp_ns + len(self.sent) * PERIOD_15HZ
        self.color = self.colors[len(self.sent) % len(self.colors)]
        self.color.header.frame_id = names.CAMERA_OPTICAL_FRAME
        self.info.header.stamp = self.color.header.stamp = ns_to_time(stamp)
        self.depth.header.stamp = ns_to_time(stamp + self.depth_offset_ns)
        self.info_pub.publish(self.info)
        self.color_pub.publish(self.color)
        self.depth_pub.publish(self.depth)
        self.sent.append(stamp)

    def destroy(self):
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
        for publisher in (self.color_pub, self.depth_pub, self.info_pub):
            self.node.destroy_publisher(publisher)


@pytest.fixture
def heightmap_graph(ros_node, launch):
    """start(parameters) -> (heightmap_node process, /heightmap recorder); cameras made with camera()."""
    made = []

    def start(parameters=None):
        process = launch("impurity_attention", "heightmap_node",
                         ros_args({"log_throttle": 0.2, **(parameters or {})}))
        recorder = TopicRecorder(ros_node, Heightmap, names.HEIGHTMAP_TOPIC, RELIABLE)
        made.append(recorder)
        spin_until(ros_node, lambda: recorder.subscription.get_publisher_count() >= 1, WAIT,
                   "heightmap_node's /heightmap publisher", (process,))
        return process, recorder

    def camera(*args, **kwargs):
        made.append(StreamingCamera(ros_node, *args, **kwargs))
        return made[-1]

    yield start, camera
    for thing in made:
        thing.destroy()


def scene(seed=11, width=640, height=480):
    """Boxes and their frame; small frames (320 x 240) where every frame counts: best-effort transport
    loses more of the large ones."""
    boxes = random_boxes(seed, num_product=15, num_impurities=1)
    intrinsics, pose = overhead_camera(width=width, height=height)
    return boxes, render_boxes(boxes, width, height, intrinsics, pose)


def now_ns(node) -> int:
    return node.get_clock().now().nanoseconds


def logged(node, process, text, what=None):
    spin_until(node, lambda: text in process.output(), WAIT, what or f"'{text}' in {process.name}'s log",
               (process,))


def test_frames_on_the_cameras_own_clock_are_warned_once(ros_node, heightmap_graph):
    """Frames stamped 1000 s before the nodes' clock."""
    start, camera = heightmap_graph
    process, heightmaps = start()
    _, frame = scene()
    stream = camera(frame, now_ns(ros_node) - 1000 * 1_000_000_000)
    stream.start((process,))
    heightmaps.wait_for(5, WAIT, processes=(process,))  # still turned into heightmaps
    output = process.output()
    assert output.count("camera frames are stamped") == 1, output[-3000:]
    line = next(line for line in output.splitlines() if "camera frames are stamped" in line)
    assert "stamped -1000." in line and "s from this node's clock" in line
    assert "use_sim_time" in line and "global_time_enabled" in line


def test_depth_stamped_20ms_after_colour_pairs_with_the_defaults(ros_node, heightmap_graph):
    """A 15 Hz stream whose depth is stamped 20 ms after its colour."""
    start, camera = heightmap_graph
    process, heightmaps = start()
    _, frame = scene(width=320, height=240)
    # Streamed until 25 heightmaps came back (at most 300 frames): the best-effort camera topics lose the
    # frames sent before the node's subscriptions have discovered this publisher, and on a loaded machine
    # that took more than 5 of a fixed 30. Every heightmap must come from a sent pair.
    stream = camera(frame, now_ns(ros_node), frames=300, depth_offset_ns=20_000_000, depth_units=0.001)
    stream.start((process,))
    received = heightmaps.wait_for(25, WAIT, processes=(process,))
    assert {time_to_ns(m.header.stamp) for m in received} <= set(stream.sent)
    assert "beyond the pairing tolerance" not in process.output()


def test_a_tolerance_below_the_offset_is_warned_with_the_offset_and_the_parameter(ros_node, heightmap_graph):
    start, camera = heightmap_graph
    process, heightmaps = start({"sync_tolerance": 0.01})
    _, frame = scene()
    stream = camera(frame, now_ns(ros_node), depth_offset_ns=20_000_000)
    stream.start((process,))
    logged(ros_node, process, "depth is stamped +20.0 ms from its nearest colour frame, beyond the pairing "
                              "tolerance of 10.0 ms (sync_tolerance=0.01 s); set sync_tolerance above the "
                              "offset")
    assert "frame(s) dropped unpaired" in process.output() and not heightmaps.messages


def test_an_offset_near_one_frame_period_is_named_and_depth_offset_pairs_the_right_frames(
        ros_node, heightmap_graph):
    """Depth stamped 60 ms after its colour frame at 15 Hz (66.7 ms): each colour frame pairs with the
    depth of the frame before; the warning names the offset and depth_offset. Set, frames pair as taken."""
    start, camera = heightmap_graph
    process, _ = start()
    _, frame = scene(width=320, height=240)
    first = camera(frame, now_ns(ros_node), frames=300, depth_offset_ns=60_000_000)
    first.start((process,))
    logged(ros_node, process, "set depth_offset to 0.0600 s")
    first.frames = len(first.sent)  # stops it
    assert "depth is stamped +60.0 ms from the nearest colour frame, about one frame period (66.7 ms) off" \
        in process.output()
    process.stop()  # its heightmaps would mix with the next node's
    fixed, heightmaps = start({"depth_offset": 0.06})
    stream = camera(frame, now_ns(ros_node), frames=300, depth_offset_ns=60_000_000)
    stream.start((fixed,))
    received = heightmaps.wait_for(10, WAIT, processes=(fixed,))
    assert {time_to_ns(m.header.stamp) for m in received} <= set(stream.sent)


def test_brightness_flickering_between_frames_is_warned_naming_the_auto_exposure(ros_node, heightmap_graph):
    start, camera = heightmap_graph
    process, heightmaps = start()
    _, frame = scene(width=320, height=240)
    camera(frame, now_ns(ros_node), frames=300, flicker=0.3).start((process,))
    logged(ros_node, process, "colour brightness unsteady")
    assert "rgb_camera.enable_auto_exposure" in process.output()
    assert "power_line_frequency" in process.output()
    heightmaps.wait_for(1, WAIT, processes=(process,))  # warned, not dropped


def test_d405_depth_needs_depth_scale_and_its_frames_are_dropped_saying_so(ros_node, heightmap_graph):
    """16UC1 in 0.1 mm. With the default depth_scale the log names it and the right value, and no heightmap
    comes of such a frame: each is dropped with its reason on /heightmap/dropped."""
    start, camera = heightmap_graph
    process, heightmaps = start()
    dropped = TopicRecorder(ros_node, String, names.HEIGHTMAP_DROPPED_TOPIC, 10)
    _, frame = scene()
    camera(frame, now_ns(ros_node), depth_units=0.0001).start((process,))
    logged(ros_node, process, "frame dropped: depth does not fit the table")
    assert "these depths fit depth_scale=0.0001" in process.output()
    reasons = dropped.wait_for(3, WAIT, processes=(process,))
    assert all("depth_scale=0.0001" in reason.data for reason in reasons)
    assert not heightmaps.messages
    dropped.destroy()


def test_depth_in_millimetres_ends_the_episode_naming_the_units(ros_node, heightmap_graph, launch, tmp_path):
    """32FC1 in mm, on a cell that counts by perception: the episode ends unusable_input with the heightmap
    node's reason, not "nothing left" and not at its decision timeout (120 s here)."""
    start, camera = heightmap_graph
    process, _ = start()
    episode = launch("impurity_policy", "episode_node", ros_args(
        {"record_dir": str(tmp_path), "use_ground_truth": False, "scene_service_timeout": 0.0,
         "decision_timeout": 120.0}))
    _, frame = scene()
    camera(dataclasses.replace(frame, depth=frame.depth * 1000.0), now_ns(ros_node)).start((process,))
    action = ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode, process])
    handle, wrapped = action.run(RunEpisode.Goal(scenario="random", seed=1), timeout=WAIT)
    assert handle.accepted and wrapped.status == GoalStatus.STATUS_ABORTED
    reason = wrapped.result.termination_reason
    assert reason.startswith("unusable_input: the heightmap node dropped 3 camera frames in a row"), reason
    assert "Likely cause: the depth units: 32FC1 depth must be metres" in reason
    assert wrapped.result.actions == 0
    action.destroy()


def test_a_camera_tilted_against_its_calibration_is_dropped_naming_the_pose(ros_node, heightmap_graph):
    """Tilted 12 deg about x and 12 deg about y, calibrated as looking straight down."""
    start, camera = heightmap_graph
    process, heightmaps = start()
    dropped = TopicRecorder(ros_node, String, names.HEIGHTMAP_DROPPED_TOPIC, 10)
    boxes = random_boxes(11, num_product=15, num_impurities=1)
    turn = np.eye(4)
    c, s = np.cos(np.radians(12.0)), np.sin(np.radians(12.0))
    turn[:3, :3] = np.array([[1, 0, 0], [0, c, -s], [0, s, c]]) @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    intrinsics, pose = overhead_camera()
    tilted = render_boxes(boxes, intrinsics=intrinsics, camera_pose=pose @ turn)
    camera(tilted, now_ns(ros_node)).start((process,))
    reasons = dropped.wait_for(2, WAIT, processes=(process,))
    assert all("tilted 16.9 deg" in reason.data and "camera_orientation" in reason.data for reason in reasons)
    assert not heightmaps.messages
    dropped.destroy()


def test_d405_depth_with_depth_scale_gives_the_right_map(ros_node, heightmap_graph):
    start, camera = heightmap_graph
    process, heightmaps = start({"depth_scale": 0.0001})
    boxes, frame = scene()
    camera(frame, now_ns(ros_node), depth_units=0.0001).start((process,))
    heightmap = heightmaps.wait_for(2, WAIT, processes=(process,))[-1]
    height = image_to_numpy(heightmap.height, ("32FC1",))
    assert np.count_nonzero(height > 0.025) > 15 * 200  # 16 boxes of 15 x 15 cells, 3 cm high
    assert float(height.max()) == pytest.approx(0.03, abs=1e-3)
    assert "depth does not fit the table" not in process.output()


@pytest.mark.parametrize("encoding", ["bgra8", "rgba8"])
def test_four_channel_colour_is_accepted(ros_node, heightmap_graph, encoding):
    """A ZED-like camera publishing bgra8 / rgba8."""
    start, camera = heightmap_graph
    process, heightmaps = start()
    boxes, frame = scene()
    camera(frame, now_ns(ros_node), color_encoding=encoding).start((process,))
    heightmap = heightmaps.wait_for(1, WAIT, processes=(process,))[0]
    colour = image_to_numpy(heightmap.color, ("rgb8",))
    impurity = boxes[-1]
    assert tuple(colour[GRID.base_to_pixel(impurity.x, impurity.y)]) == impurity.color
    assert "not accepted" not in process.output()


def test_a_camera_coarser_than_the_cells_is_warned_once_and_its_gaps_filled(ros_node, heightmap_graph):
    """640x480 at 1.5 m, 2.4 mm per pixel on 2 mm cells."""
    start, camera = heightmap_graph
    process, heightmaps = start({"camera_position": [0.5, 0.0, 1.5]})
    boxes = random_boxes(11, num_product=15, num_impurities=1)
    intrinsics, pose = overhead_camera(1.5)
    frame = render_boxes(boxes, intrinsics=intrinsics, camera_pose=pose)
    camera(frame, now_ns(ros_node)).start((process,))
    received = heightmaps.wait_for(3, WAIT, processes=(process,))
    output = process.output()
    assert output.count("camera pixels cover up to 2.42 mm of the table") == 1, output[-3000:]
    assert "set resolution to 0.0024 m or more" in output
    colour = image_to_numpy(received[-1].color, ("rgb8",))
    unseen = ~colour.any(axis=2)
    assert unseen.mean() < 0.05  # a third without the gap filling


def test_an_overexposed_camera_is_warned_with_the_exposure_to_lower(ros_node, heightmap_graph):
    """A light product at the camera's ceiling (heightmap.exposure_problem): warned, not dropped."""
    start, camera = heightmap_graph
    process, heightmaps = start()
    _, frame = scene()
    frame.color[frame.labels > 0] = (255, 250, 235)  # every box clipped in R and G
    camera(frame, now_ns(ros_node)).start((process,))
    logged(ros_node, process, "colour badly exposed: the colour image is clipped")
    assert "rgb_camera.exposure" in process.output()
    heightmaps.wait_for(1, WAIT, processes=(process,))


def test_a_silent_camera_is_warned_naming_its_topics(ros_node, heightmap_graph):
    """No camera running: the node says which topics are silent and what to check, and keeps saying it."""
    start, _camera = heightmap_graph
    process, heightmaps = start({"frame_timeout": 0.5})
    logged(ros_node, process, "no camera messages on " + names.COLOR_TOPIC)
    line = next(line for line in process.output().splitlines() if "no camera messages" in line)
    assert names.DEPTH_TOPIC in line and names.CAMERA_INFO_TOPIC in line and "align_depth.enable" in line
    spin_until(ros_node, lambda: process.output().count("no camera messages") >= 2, WAIT,
               "the warning repeated while the camera stays silent", (process,))
    assert not heightmaps.messages
