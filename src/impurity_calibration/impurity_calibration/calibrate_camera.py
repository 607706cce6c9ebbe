"""calibrate_camera: the camera's pose in base_link from a ChArUco board on the table, written to the
calibration file (bringup/config/camera_calibration.yaml) that heightmap_node and sim_cell read.

Live, on a cell: with the camera driver running (realsense2_camera), lay the printed board flat on the
table, measure where its origin lies in base_link (the lower-left outer corner of the squares, the
page upright as read; see impurity_calibration.calibration) and its yaw, or touch the origin and the
other end of the bottom row of squares with the tool tip, and run

  ros2 run impurity_calibration calibrate_camera --board-position 0.32 -0.14 0.0 --board-yaw 0.0
  ros2 run impurity_calibration calibrate_camera --board-position 0.32 -0.14 0.0 \
      --board-x-point 0.68 -0.14 0.0

It subscribes to the colour image and camera_info (impurity_common.names: COLOR_TOPIC,
CAMERA_INFO_TOPIC; rename with `--ros-args -r`), waits at most --timeout s, calibrates on --frames
frames, prints the pose, the reprojection error and how far the frames spread, and writes the file.
Offline, from a saved image and its camera_info (camera_calibration_parsers YAML, or what
`ros2 topic echo --once /camera/camera/color/camera_info > info.yaml` prints):

  calibrate_camera --image board.png --camera-info info.yaml --board-position 0.32 -0.14 0.0

Print the board: `calibrate_camera --print-board board.png --dpi 300` (print at 100 %, then measure a
square and a marker and give them with --square-length / --marker-length).

Exit status: 0 written (or checked with --check, or printed); 1 the calibration failed, with what to
change (no frame in time, board not found, too few corners, unusable intrinsics, unwritable file);
2 bad arguments.
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time

import cv2
import numpy as np
import rclpy
from rclpy.qos import qos_profile_sensor_data
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import CameraInfo, Image

from impurity_calibration import calibration
from impurity_calibration.calibration import CalibrationError, CameraIntrinsics, CharucoBoardSpec
from impurity_common import names
from impurity_common.conversions import ImageFormatError, image_to_rgb
from impurity_common.node_main import init_with_stop_event

DEFAULTS = CharucoBoardSpec()
FAILURE_EXIT_CODE = 1
PREFIX = "calibrate_camera:"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="calibrate_camera", formatter_class=argparse.RawDescriptionHelpFormatter,
        description=__doc__.split("\n\n")[0],
        epilog="Board frame: origin at the lower-left outer corner of the squares with the page upright, "
               "x to the right, y up the page, z out of the face; --board-yaw turns it about +z_base.")
    board = parser.add_argument_group("the board (what was printed)")
    board.add_argument("--squares", nargs=2, type=int, metavar=("X", "Y"),
                       default=(DEFAULTS.squares_x, DEFAULTS.squares_y),
                       help="squares along the board's x and y (default: %(default)s)")
    board.add_argument("--square-length", type=float, default=DEFAULTS.square_length,
                       help="side of a square as printed, m (default: %(default)s)")
    board.add_argument("--marker-length", type=float, default=DEFAULTS.marker_length,
                       help="side of a marker as printed, m (default: %(default)s)")
    board.add_argument("--dictionary", default=DEFAULTS.dictionary,
                       help="ArUco dictionary, a cv2.aruco DICT_* name (default: %(default)s)")
    place = parser.add_argument_group("where the board lies")
    place.add_argument("--board-position", nargs=3, type=float, metavar=("X", "Y", "Z"),
                       help=f"board origin in {names.BASE_FRAME}, m (z: the table top plus the board's "
                            "thickness)")
    turn = place.add_mutually_exclusive_group()
    turn.add_argument("--board-yaw", type=float, default=0.0,
                      help="board x from +x_base about +z_base, rad (default: %(default)s)")
    turn.add_argument("--board-x-point", nargs=3, type=float, metavar=("X", "Y", "Z"),
                      help="instead of --board-yaw: the outer corner at the other end of the bottom row of "
                           f"squares in {names.BASE_FRAME}, m (touched with the tool tip, as the origin)")
    source = parser.add_argument_group("the image (default: live, from the camera driver)")
    source.add_argument("--image", type=pathlib.Path,
                        help="offline: a colour image of the board (PNG, JPEG)")
    source.add_argument("--camera-info", type=pathlib.Path,
                        help="offline: the camera_info of that image (YAML)")
    source.add_argument("--frames", type=int, default=5,
                        help="live: frames to calibrate on and combine (default: %(default)s)")
    source.add_argument("--timeout", type=float, default=10.0,
                        help="live: s to wait for the frames (default: %(default)s)")
    out = parser.add_argument_group("output")
    out.add_argument("--output", type=pathlib.Path, default=pathlib.Path(calibration.CALIBRATION_FILE),
                     help="calibration file to write (default: %(default)s, from the repository root)")
    out.add_argument("--note", default="", help="a line for the file's header (e.g. who, which cell)")
    out.add_argument("--check", action="store_true", help="print the pose and the error, write nothing")
    out.add_argument("--debug-image", type=pathlib.Path,
                     help="also write the image with the corners found and the board's axes drawn")
    out.add_argument("--min-corners", type=int, default=calibration.DEFAULT_MIN_CORNERS,
                     help="fewest chessboard corners to accept (default: %(default)s)")
    printing = parser.add_argument_group("printing the board")
    printing.add_argument("--print-board", type=pathlib.Path, metavar="PNG",
                          help="write the board to print (at 100 %% scale) and exit")
    printing.add_argument("--dpi", type=float, default=300.0, help="print resolution (default: %(default)s)")
    return parser


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.print_board is None and args.board_position is None:
        parser.error("--board-position X Y Z is required: where the board's origin lies in base_link (m)")
    if (args.image is None) != (args.camera_info is None):
        parser.error("--image and --camera-info go together (offline mode); give both or neither")
    if args.frames < 1 or not (math.isfinite(args.timeout) and args.timeout > 0):
        parser.error("--frames must be >= 1 and --timeout > 0 s")
    return args


def say(text: str) -> None:
    print(f"{PREFIX} {text}", flush=True)


def hint(error: CalibrationError) -> str:
    """What to change, beside the error's own text."""
    if isinstance(error, calibration.BoardNotFound):
        return ("look at the image (live: `ros2 run rqt_image_view rqt_image_view " + names.COLOR_TOPIC +
                "`): the whole board should be in it, flat, sharp, without glare")
    if isinstance(error, calibration.TooFewCorners):
        return "more of the board in view, less glare, or a larger board (--squares, --square-length)"
    if isinstance(error, calibration.InvalidIntrinsics):
        return "the camera_info of the colour stream (its size must match the image)"
    return ""


def report_failure(error: CalibrationError) -> int:
    extra = hint(error)
    say(f"FAILED: {error}" + (f"\n{PREFIX} what to change: {extra}" if extra else ""))
    return FAILURE_EXIT_CODE


def draw_debug_image(path: pathlib.Path, rgb: np.ndarray, spec: CharucoBoardSpec,
                     intrinsics: CameraIntrinsics, result: calibration.CameraCalibration,
                     base_from_board: np.ndarray) -> None:
    """The image with the corners found and the board's axes (x red, y green, z blue, two squares long)."""
    image = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    detection = calibration.detect_board(rgb, spec, intrinsics)
    cv2.aruco.drawDetectedCornersCharuco(image, detection.corners.reshape(-1, 1, 2).astype(np.float32),
                                         cornerColor=(0, 0, 255))
    camera_from_board = np.linalg.inv(result.pose) @ base_from_board
    rvec = cv2.Rodrigues(camera_from_board[:3, :3])[0]
    cv2.drawFrameAxes(image, intrinsics.matrix, intrinsics.distortion, rvec, camera_from_board[:3, 3],
                      spec.square_length * 2)
    cv2.imwrite(str(path), image)


def finish(args, spec, intrinsics, base_from_board, result, rgb) -> int:
    """Print the result; write the file (unless --check) and the debug image."""
    print(calibration.summary(result), flush=True)
    if args.debug_image is not None:
        draw_debug_image(args.debug_image, rgb, spec, intrinsics, result, base_from_board)
        say(f"debug image {args.debug_image}")
    if args.check:
        say("--check: nothing written")
        return 0
    try:
        path = calibration.write_calibration_file(args.output, result, args.note)
    except (CalibrationError, OSError) as error:
        say(f"FAILED: {error}")
        return FAILURE_EXIT_CODE
    say(f"wrote {path.resolve()}; the cell's nodes read it when they start: restart the cell to use it")
    return 0


def calibrate_offline(args, spec, base_from_board) -> int:
    intrinsics = CameraIntrinsics.from_yaml_file(args.camera_info)
    bgr = cv2.imread(str(args.image), cv2.IMREAD_COLOR)
    if bgr is None:
        raise CalibrationError(f"cannot read the image {args.image} (missing, or not an image OpenCV reads)")
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    result = calibration.calibrate(rgb, spec, intrinsics, base_from_board, args.min_corners)
    result.method = f"calibrate_camera on {args.image.name}"
    return finish(args, spec, intrinsics, base_from_board, result, rgb)


def calibrate_live(args, spec, base_from_board, ros_args: list[str]) -> int:
    """Subscribe, calibrate on --frames fresh frames within --timeout s, combine them."""
    stop = init_with_stop_event(ros_args)  # Ctrl-C ends the wait; nothing is written
    node = rclpy.create_node("calibrate_camera")
    state = {"info": None, "image": None, "images": 0}

    def on_info(msg):
        state["info"] = msg

    def on_image(msg):
        state["image"], state["images"] = msg, state["images"] + 1

    node.create_subscription(CameraInfo, names.CAMERA_INFO_TOPIC, on_info, qos_profile_sensor_data)
    node.create_subscription(Image, names.COLOR_TOPIC, on_image, qos_profile_sensor_data)
    color_topic = node.resolve_topic_name(names.COLOR_TOPIC)
    info_topic = node.resolve_topic_name(names.CAMERA_INFO_TOPIC)
    say(f"waiting up to {args.timeout:g} s for {args.frames} frame(s) on {color_topic} with {info_topic}")
    results, last_error, rgb, intrinsics = [], None, None, None
    deadline = time.monotonic() + args.timeout
    try:
        while len(results) < args.frames and time.monotonic() < deadline and not stop.is_set():
            rclpy.spin_once(node, timeout_sec=0.1)
            if state["image"] is None or state["info"] is None:
                continue
            msg, state["image"] = state["image"], None
            try:
                intrinsics = CameraIntrinsics.from_camera_info(state["info"])
                frame = image_to_rgb(msg)
                result = calibration.calibrate(frame, spec, intrinsics, base_from_board, args.min_corners)
            except (CalibrationError, ImageFormatError) as error:
                if str(error) != str(last_error):
                    say(f"frame {state['images']}: {error}")
                last_error = error
                continue
            rgb = frame
            results.append(result)
            say(f"frame {len(results)}/{args.frames}: {result.corner_count} corners, reprojection "
                f"{result.rms_px:.3f} px RMS")
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    if stop.is_set():
        say("interrupted: nothing written")
        return FAILURE_EXIT_CODE
    if not results:
        if state["images"] == 0 or state["info"] is None:
            seen = ((color_topic, state["images"]), (info_topic, state["info"]))
            missing = [topic for topic, received in seen if not received]
            say(f"FAILED: nothing on {' and '.join(missing)} within {args.timeout:g} s: is the camera driver "
                "running (ros2 launch realsense2_camera rs_launch.py), on this ROS_DOMAIN_ID, with the "
                "colour stream enabled? Rename topics with --ros-args -r; wait longer with --timeout")
            return FAILURE_EXIT_CODE
        if isinstance(last_error, CalibrationError):
            return report_failure(last_error)
        say(f"FAILED: {last_error}")
        return FAILURE_EXIT_CODE
    if len(results) < args.frames:
        say(f"only {len(results)} of {args.frames} frames within {args.timeout:g} s; using them")
    combined = calibration.combine(results)
    combined.method = f"calibrate_camera on {len(results)} frame(s) of {color_topic}"
    return finish(args, spec, intrinsics, base_from_board, combined, rgb)


def main(argv: list[str] | None = None) -> int:
    """Entry point (console script): parse, then print the board, or calibrate offline or live; returns
    the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(remove_ros_args(args=argv))
    try:
        spec = CharucoBoardSpec(int(args.squares[0]), int(args.squares[1]), args.square_length,
                                args.marker_length, args.dictionary)
        if args.print_board is not None:
            image = calibration.printable_board_image(spec, args.dpi)
            if not cv2.imwrite(str(args.print_board), image):
                raise CalibrationError(f"cannot write {args.print_board}")
            say(f"wrote {args.print_board} ({image.shape[1]}x{image.shape[0]} px): print it at 100 % scale "
                f"({args.dpi:g} dpi), {spec.describe()}; measure a square and a marker on the print")
            return 0
        if args.board_x_point is not None:
            args.board_yaw = calibration.board_yaw_from_points(args.board_position, args.board_x_point, spec)
        base_from_board = calibration.board_pose_on_table(args.board_position, args.board_yaw)
        say(f"board {spec.describe()} at {list(args.board_position)} m, yaw {args.board_yaw:.4f} rad")
        if args.image is not None:
            return calibrate_offline(args, spec, base_from_board)
        return calibrate_live(args, spec, base_from_board, ["calibrate_camera", *argv])
    except CalibrationError as error:
        return report_failure(error)
    except KeyboardInterrupt:
        say("interrupted: nothing written")
        return FAILURE_EXIT_CODE


if __name__ == "__main__":
    sys.exit(main())
