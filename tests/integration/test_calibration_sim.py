"""Camera calibration against the simulator: a ChArUco board lies textured on the PyBullet table, the
simulated camera renders it from known poses (TinyRenderer, 640x480, the sim's intrinsics), and the
calibration recovers each pose within 5 mm and 0.5 deg (the acceptance bound). The calibrate_camera
tool runs on such renders offline (--image) and live (frames published on the camera topics)."""

import math
import signal

import cv2
import numpy as np
import pytest
import yaml
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image

from impurity_calibration import calibrate_camera, calibration
from impurity_calibration.calibration import CameraIntrinsics, CharucoBoardSpec
from impurity_common import names
from impurity_common.conversions import numpy_to_image
from ros_harness import spin_until, wait_for_subscribers

world_module = pytest.importorskip("ur5_driver_sim.core.world")
from ur5_driver_sim.core.camera import CameraModel  # noqa: E402
from ur5_driver_sim.core.charuco_board import look_at, place_board, render_color  # noqa: E402

POSITION_TOLERANCE = 0.005  # m (acceptance)
ANGLE_TOLERANCE = 0.5  # deg (acceptance)
SPEC = CharucoBoardSpec()
PAPER = 0.001  # m: the board's face above the table top
BOARD_ORIGIN = (0.5 - SPEC.width / 2, -SPEC.height / 2, PAPER)  # the board centred on the workspace
BOARD_POSE = calibration.board_pose_on_table(BOARD_ORIGIN)
TILTED_EYE, ROLLED_EYE = (0.75, 0.2, 0.65), (0.3, -0.25, 0.7)
CAMERAS = {
    "overhead": CameraModel(),  # the cell's camera: 0.75 m above the workspace centre, straight down
    "tilted_from_the_front": CameraModel(position=TILTED_EYE,
                                         orientation=look_at(TILTED_EYE, (0.5, 0.0, 0.0))),
    "tilted_and_rolled": CameraModel(position=ROLLED_EYE,
                                     orientation=look_at(ROLLED_EYE, (0.52, 0.02, 0.0), up=(1.0, 0.0, 0.0))),
}


def intrinsics_of(camera: CameraModel) -> CameraIntrinsics:
    return CameraIntrinsics(camera.intrinsics, np.zeros(5), camera.width, camera.height)


@pytest.fixture(scope="module")
def world():
    cell_world = world_module.CellWorld(mode="floating")  # the gripper parks above the camera
    yield cell_world
    cell_world.close()


@pytest.fixture(scope="module")
def board(world):
    return place_board(world.pb, SPEC, BOARD_POSE)


@pytest.fixture(scope="module")
def renders(world, board):
    return {name: render_color(world.pb, camera) for name, camera in CAMERAS.items()}


@pytest.mark.parametrize("name", list(CAMERAS))
def test_the_simulated_cameras_pose_is_recovered_within_5_mm_and_half_a_degree(renders, name):
    camera = CAMERAS[name]
    result = calibration.calibrate(renders[name], SPEC, intrinsics_of(camera), BOARD_POSE)
    distance, angle = calibration.pose_difference(result.pose, camera.pose)
    print(f"{name}: {distance * 1000:.2f} mm, {angle:.3f} deg, {result.rms_px:.3f} px RMS, "
          f"{result.corner_count} corners")
    assert distance < POSITION_TOLERANCE and angle < ANGLE_TOLERANCE, (distance, angle)
    assert result.corner_count == SPEC.corner_count and result.rms_px < calibration.REPROJECTION_WARNING_PX


def test_a_render_averaged_over_finer_pixels_fits_better(world, board, renders):
    """TinyRenderer samples one point per pixel; averaging a 2x finer render (as a sensor integrates
    light over its pixels) halves the reprojection error of a tilted view."""
    camera = CAMERAS["tilted_and_rolled"]
    plain = calibration.calibrate(renders["tilted_and_rolled"], SPEC, intrinsics_of(camera), BOARD_POSE)
    finer = calibration.calibrate(render_color(world.pb, camera, supersample=2), SPEC, intrinsics_of(camera),
                                  BOARD_POSE)
    assert finer.rms_px < 0.6 * plain.rms_px
    distance, angle = calibration.pose_difference(finer.pose, camera.pose)
    assert distance < POSITION_TOLERANCE and angle < ANGLE_TOLERANCE, (distance, angle)


def test_the_tilted_views_are_really_tilted():
    """The three poses differ: the test covers more than one view of the board."""
    overhead = CAMERAS["overhead"].pose
    for name in ("tilted_from_the_front", "tilted_and_rolled"):
        distance, angle = calibration.pose_difference(CAMERAS[name].pose, overhead)
        assert distance > 0.2 and angle > 15.0, name


def test_a_board_turned_on_the_table_is_recovered_too(world, board):
    turned = calibration.board_pose_on_table((0.62, -0.2, PAPER), math.radians(80))
    position, quaternion = calibration.position_and_quaternion(turned)
    camera = CAMERAS["tilted_from_the_front"]
    world.pb.resetBasePositionAndOrientation(board.body, position, quaternion)
    try:
        result = calibration.calibrate(render_color(world.pb, camera), SPEC, intrinsics_of(camera), turned)
    finally:
        world.pb.resetBasePositionAndOrientation(board.body, *calibration.position_and_quaternion(BOARD_POSE))
    distance, angle = calibration.pose_difference(result.pose, camera.pose)
    assert distance < POSITION_TOLERANCE and angle < ANGLE_TOLERANCE, (distance, angle)


# ---------------------------------------------------------------------------------- the tool, offline
def save_view(tmp_path, image, camera):
    picture, info = tmp_path / "board.png", tmp_path / "camera_info.yaml"
    cv2.imwrite(str(picture), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    info.write_text(yaml.safe_dump({"width": camera.width, "height": camera.height,
                                    "distortion_model": "plumb_bob", "d": [0.0] * 5,
                                    "k": camera.intrinsics.ravel().tolist()}))
    return picture, info


def board_arguments():
    return ["--board-position", *(str(v) for v in BOARD_ORIGIN), "--board-yaw", "0"]


def test_the_tool_calibrates_from_a_saved_image_and_writes_the_file(tmp_path, renders, capsys):
    camera = CAMERAS["tilted_and_rolled"]
    picture, info = save_view(tmp_path, renders["tilted_and_rolled"], camera)
    output = tmp_path / "camera_calibration.yaml"
    x_point = (BOARD_ORIGIN[0] + SPEC.width, BOARD_ORIGIN[1], BOARD_ORIGIN[2])  # the bottom row's other end
    status = calibrate_camera.main(["--image", str(picture), "--camera-info", str(info),
                                    "--board-position", *(str(v) for v in BOARD_ORIGIN),
                                    "--board-x-point", *(str(v) for v in x_point),
                                    "--output", str(output), "--note", "simulated cell",
                                    "--debug-image", str(tmp_path / "debug.png")])
    printed = capsys.readouterr().out
    assert status == 0, printed
    position, orientation = calibration.read_calibration_file(output)
    distance, angle = calibration.pose_difference(calibration.pose_matrix(position, orientation), camera.pose)
    assert distance < POSITION_TOLERANCE and angle < ANGLE_TOLERANCE
    assert "reprojection error" in printed and f"wrote {output}" in printed
    assert "# simulated cell" in output.read_text() and "on board.png" in output.read_text()
    debug = cv2.imread(str(tmp_path / "debug.png"))
    assert debug.shape == (camera.height, camera.width, 3)
    assert np.any(debug != cv2.imread(str(picture)))  # corners and axes drawn


def test_the_tool_says_what_to_change_when_the_board_is_not_in_view(tmp_path, world, board, capsys):
    away = CameraModel(position=(0.5, 0.0, 0.75), orientation=look_at((0.5, 0.0, 0.75), (1.5, 1.5, 0.0)))
    picture, info = save_view(tmp_path, render_color(world.pb, away), away)
    output = tmp_path / "camera_calibration.yaml"
    status = calibrate_camera.main(["--image", str(picture), "--camera-info", str(info), *board_arguments(),
                                    "--output", str(output)])
    printed = capsys.readouterr().out
    assert status == calibrate_camera.FAILURE_EXIT_CODE
    assert "FAILED: no marker of DICT_5X5_100" in printed and "what to change:" in printed
    assert not output.exists()


def test_the_tool_prints_a_board_at_the_given_resolution(tmp_path, capsys):
    path = tmp_path / "board.png"
    assert calibrate_camera.main(["--print-board", str(path), "--dpi", "150"]) == 0
    printed = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    assert printed.shape == calibration.printable_board_image(SPEC, 150).shape
    assert "print it at 100 % scale" in capsys.readouterr().out


# ------------------------------------------------------------------------------------- the tool, live
def test_the_tool_calibrates_from_the_camera_topics(tmp_path, renders, ros_node, launch):
    camera = CAMERAS["tilted_from_the_front"]
    image = numpy_to_image(renders["tilted_from_the_front"], "rgb8")
    image.header.frame_id = info_frame = names.CAMERA_OPTICAL_FRAME
    info = CameraInfo(width=camera.width, height=camera.height, distortion_model="plumb_bob", d=[0.0] * 5,
                      k=camera.intrinsics.ravel().tolist())
    info.header.frame_id = info_frame
    image_publisher = ros_node.create_publisher(Image, names.COLOR_TOPIC, qos_profile_sensor_data)
    info_publisher = ros_node.create_publisher(CameraInfo, names.CAMERA_INFO_TOPIC, qos_profile_sensor_data)
    timer = ros_node.create_timer(0.2, lambda: (info_publisher.publish(info), image_publisher.publish(image)))
    output = tmp_path / "camera_calibration.yaml"
    try:
        tool = launch("impurity_calibration", "calibrate_camera",
                      [*board_arguments(), "--frames", "3", "--timeout", "60", "--output", str(output)])
        wait_for_subscribers(ros_node, image_publisher, timeout=30.0, processes=[tool])
        spin_until(ros_node, lambda: not tool.alive, 90.0, "calibrate_camera to finish")
    finally:
        ros_node.destroy_timer(timer)
        ros_node.destroy_publisher(image_publisher)
        ros_node.destroy_publisher(info_publisher)
    assert tool.process.returncode == 0, tool.output()
    position, orientation = calibration.read_calibration_file(output)
    distance, angle = calibration.pose_difference(calibration.pose_matrix(position, orientation), camera.pose)
    assert distance < POSITION_TOLERANCE and angle < ANGLE_TOLERANCE
    assert "3 frames within" in tool.output()


def test_the_tool_without_a_camera_gives_up_in_time_naming_the_topics(launch, ros_node):
    """Renamed topics (remapping, as a cell with another camera name would) that nothing publishes."""
    color, info = "/no_camera/color/image_raw", "/no_camera/color/camera_info"
    tool = launch("impurity_calibration", "calibrate_camera",
                  [*board_arguments(), "--timeout", "1", "--check", "--ros-args",
                   "-r", f"{names.COLOR_TOPIC}:={color}", "-r", f"{names.CAMERA_INFO_TOPIC}:={info}"])
    spin_until(ros_node, lambda: not tool.alive, 30.0, "calibrate_camera to give up")
    assert tool.process.returncode == calibrate_camera.FAILURE_EXIT_CODE
    assert f"nothing on {color} and {info} within 1 s: is the camera driver running" in tool.output()


def test_the_tool_interrupted_while_waiting_writes_nothing_and_says_so(launch, ros_node, tmp_path):
    """Ctrl-C during the live wait: one line, the failure status, no traceback, no file."""
    output = tmp_path / "camera_calibration.yaml"
    tool = launch("impurity_calibration", "calibrate_camera",
                  [*board_arguments(), "--timeout", "60", "--output", str(output), "--ros-args",
                   "-r", f"{names.COLOR_TOPIC}:=/no_camera/color/image_raw"])
    spin_until(ros_node, lambda: "waiting up to 60 s" in tool.output(), 30.0, "calibrate_camera to wait",
               [tool])
    tool.send_signal(signal.SIGINT)
    spin_until(ros_node, lambda: not tool.alive, 30.0, "calibrate_camera to stop")
    assert tool.process.returncode == calibrate_camera.FAILURE_EXIT_CODE, tool.output()
    assert "interrupted: nothing written" in tool.output()
    assert "Traceback" not in tool.output()
    assert not output.exists()
