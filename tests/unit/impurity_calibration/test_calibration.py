"""The camera pose from a ChArUco board (impurity_calibration.calibration), on synthetic views: the board
image warped into a pinhole camera at a known pose (a plane's homography), anti-aliased as a sensor
integrates light over its pixels. No simulator: tests/integration/test_calibration_sim.py renders it."""

import math

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impurity_calibration import calibration
from impurity_calibration.calibration import (
    BoardNotFound,
    CalibrationError,
    CalibrationFileError,
    CameraIntrinsics,
    CharucoBoardSpec,
    InvalidIntrinsics,
    TooFewCorners,
)
from impurity_common import cell

SPEC = CharucoBoardSpec()
WIDTH, HEIGHT = cell.CAMERA_WIDTH, cell.CAMERA_HEIGHT
K = np.array([[cell.CAMERA_FX, 0.0, cell.CAMERA_CX], [0.0, cell.CAMERA_FY, cell.CAMERA_CY], [0.0, 0.0, 1.0]])
INTRINSICS = CameraIntrinsics(K, np.zeros(5), WIDTH, HEIGHT)
# The board centred on the workspace, lying on the table (its origin: the squares' lower-left corner).
BOARD_ON_TABLE = calibration.board_pose_on_table((0.5 - SPEC.width / 2, -SPEC.height / 2, 0.0))
TEXELS_PER_SQUARE = 100
SUPERSAMPLE = 4
# Recovered from an ideal anti-aliased view (measured: <= 1.1 mm, <= 0.05 deg over the poses below).
POSITION_TOLERANCE = 0.002  # m
ANGLE_TOLERANCE = 0.1  # deg


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """4x4 T_base_camera of an optical frame (z forward, x right, y down) at eye looking at target."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(-up, z)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    pose[:3, 3] = eye
    return pose


OVERHEAD = calibration.pose_matrix(cell.CAMERA_POSITION, cell.CAMERA_ORIENTATION)
CAMERA_POSES = {
    "overhead": OVERHEAD,
    "tilted_from_the_front": look_at((0.8, 0.15, 0.6), (0.5, 0.0, 0.0)),
    "tilted_and_rolled": look_at((0.3, -0.25, 0.65), (0.52, 0.03, 0.0), up=(1.0, 0.2, 0.0)),
}


def synthetic_view(base_from_camera, base_from_board=BOARD_ON_TABLE, spec=SPEC, background=128):
    """The board seen by a camera with intrinsics K at base_from_camera: (HEIGHT, WIDTH) uint8.

    Board image pixel (u, v) (centre at u + 0.5 texels from the left of the squares' margin...) maps to
    board point x = (u + 0.5 - margin) * m_per_texel, y = height - (v + 0.5 - margin) * m_per_texel;
    the plane z = 0 maps to the image by K [r1 r2 t]. Rendered SUPERSAMPLE times finer, then averaged."""
    margin = 20
    board = calibration.board_image(spec, TEXELS_PER_SQUARE, margin)
    metres = spec.square_length / TEXELS_PER_SQUARE
    texel_to_board = np.array([[metres, 0.0, (0.5 - margin) * metres],
                               [0.0, -metres, spec.height - (0.5 - margin) * metres], [0.0, 0.0, 1.0]])
    camera_from_board = np.linalg.inv(base_from_camera) @ base_from_board
    r, t = camera_from_board[:3, :3], camera_from_board[:3, 3]
    s = SUPERSAMPLE
    fine = np.array([[s, 0.0, (s - 1) / 2], [0.0, s, (s - 1) / 2], [0.0, 0.0, 1.0]])
    homography = fine @ K @ np.column_stack([r[:, 0], r[:, 1], t]) @ texel_to_board
    image = cv2.warpPerspective(board, homography, (WIDTH * s, HEIGHT * s), flags=cv2.INTER_LINEAR,
                                borderValue=background)
    return cv2.resize(image, (WIDTH, HEIGHT), interpolation=cv2.INTER_AREA)


# ------------------------------------------------------------------------------------------ the pose
@pytest.mark.parametrize("name", list(CAMERA_POSES))
def test_a_board_seen_from_a_known_pose_gives_back_the_camera_pose(name):
    truth = CAMERA_POSES[name]
    result = calibration.calibrate(synthetic_view(truth), SPEC, INTRINSICS, BOARD_ON_TABLE)
    distance, angle = calibration.pose_difference(result.pose, truth)
    assert distance < POSITION_TOLERANCE and angle < ANGLE_TOLERANCE, (distance, angle)
    assert result.corner_count == SPEC.corner_count
    assert result.rms_px < 0.2 and result.max_px < 0.5


def test_the_board_pose_on_the_table_carries_the_camera_pose_with_it():
    """The same view with the board (and the camera) 10 cm further along y and turned 90 deg."""
    turned = calibration.board_pose_on_table((0.66, -0.12, 0.0), math.pi / 2)
    camera = turned @ np.linalg.inv(BOARD_ON_TABLE) @ CAMERA_POSES["tilted_from_the_front"]
    result = calibration.calibrate(synthetic_view(camera, turned), SPEC, INTRINSICS, turned)
    distance, angle = calibration.pose_difference(result.pose, camera)
    assert distance < POSITION_TOLERANCE and angle < ANGLE_TOLERANCE, (distance, angle)
    assert result.board_yaw == pytest.approx(math.pi / 2)


def test_the_board_yaw_follows_from_two_touched_corners():
    origin = np.array([0.32, -0.14, 0.001])
    along = np.array([math.cos(0.3), math.sin(0.3), 0.0]) * SPEC.width
    assert calibration.board_yaw_from_points(origin, origin + along, SPEC) == pytest.approx(0.3)


@pytest.mark.parametrize("x_point,message", [
    ((0.32 + 0.28, -0.14, 0.001), "lie 280.0 mm apart on the table, the squares' bottom edge is 360.0 mm"),
    ((0.32, math.nan, 0.001), "two finite points"),
])
def test_touched_corners_that_do_not_fit_the_board_are_refused(x_point, message):
    with pytest.raises(CalibrationError, match=message):
        calibration.board_yaw_from_points((0.32, -0.14, 0.001), x_point, SPEC)


def test_the_board_frame_has_its_origin_at_the_lower_left_corner_with_z_out_of_the_face():
    """OpenCV's board frame: origin upper-left, y down the page; ours: lower-left, y up, z out."""
    board_from_cv = calibration.board_from_opencv(SPEC)
    upper_left, lower_left = np.array([0, 0, 0, 1.0]), np.array([0, SPEC.height, 0, 1.0])
    assert board_from_cv @ upper_left == pytest.approx([0, SPEC.height, 0, 1])
    assert board_from_cv @ lower_left == pytest.approx([0, 0, 0, 1])
    assert np.linalg.det(board_from_cv[:3, :3]) == pytest.approx(1.0)
    assert board_from_cv[:3, 2] == pytest.approx([0, 0, -1])  # OpenCV's z (into the page) is our -z


def test_the_overhead_camera_sees_the_page_upright():
    """Board yaw 0 under the default camera: marker 0 (top-left of the printed page) in the image's
    upper-left quarter."""
    corners, ids, _ = cv2.aruco.ArucoDetector(SPEC.cv_board().getDictionary()).detectMarkers(
        synthetic_view(OVERHEAD))
    marker0 = corners[list(ids.reshape(-1)).index(0)].reshape(4, 2).mean(axis=0)
    assert marker0[0] < WIDTH / 2 and marker0[1] < HEIGHT / 2


def test_intrinsics_that_do_not_fit_the_image_raise_the_reprojection_error_and_a_warning():
    """fx 10 % off (the camera_info of another stream): the corners no longer fit one pinhole pose."""
    stretched = K.copy()
    stretched[0, 0] *= 1.1
    wrong = CameraIntrinsics(stretched, [], WIDTH, HEIGHT)
    result = calibration.calibrate(synthetic_view(OVERHEAD), SPEC, wrong, BOARD_ON_TABLE)
    assert result.rms_px > calibration.REPROJECTION_WARNING_PX
    assert "WARNING: reprojection error above 1.0 px" in calibration.summary(result)
    fitting = calibration.calibrate(synthetic_view(OVERHEAD), SPEC, INTRINSICS, BOARD_ON_TABLE)
    assert "WARNING" not in calibration.summary(fitting)


def test_a_rgb_image_and_its_grayscale_give_the_same_pose():
    gray = synthetic_view(CAMERA_POSES["tilted_from_the_front"])
    rgb = np.repeat(gray[:, :, None], 3, axis=2)
    a = calibration.calibrate(gray, SPEC, INTRINSICS, BOARD_ON_TABLE)
    b = calibration.calibrate(rgb, SPEC, INTRINSICS, BOARD_ON_TABLE)
    assert a.position == pytest.approx(b.position, abs=1e-9)


def test_frames_of_a_still_camera_combine_into_their_mean_and_spread():
    views = [calibration.calibrate(synthetic_view(pose), SPEC, INTRINSICS, BOARD_ON_TABLE)
             for pose in (OVERHEAD, OVERHEAD @ calibration.pose_matrix((0.002, 0, 0), (0, 0, 0, 1)))]
    combined = calibration.combine(views)
    assert combined.frames == 2
    assert combined.position == pytest.approx(np.mean([v.position for v in views], axis=0))
    assert combined.spread_mm == pytest.approx(1.0, abs=0.3)
    assert "2 frames within" in calibration.summary(combined)


# ----------------------------------------------------------------------------------------- the board
def test_the_board_image_puts_each_square_on_pixel_boundaries():
    image = calibration.board_image(SPEC, pixels_per_square=50, margin_px=7)
    assert image.shape == (SPEC.squares_y * 50 + 14, SPEC.squares_x * 50 + 14) and image.dtype == np.uint8
    assert (image[:7] == 255).all() and (image[:, -7:] == 255).all()  # the margin
    assert (image[7:57, 7:57] == 0).all()  # the upper-left square is black, exactly 50 px


@pytest.mark.parametrize("pixels_per_square", [128, 60])
def test_the_board_image_is_what_opencv_draws(pixels_per_square):
    """Exactly, where markers start on whole pixels (128 px squares); else within one pixel (60 px squares:
    markers start at 7.5 px)."""
    ours = calibration.board_image(SPEC, pixels_per_square)
    size = (SPEC.squares_x * pixels_per_square, SPEC.squares_y * pixels_per_square)
    opencv = SPEC.cv_board().generateImage(size, marginSize=0, borderBits=1)
    if pixels_per_square == 128:
        assert np.array_equal(ours, opencv)
    window = np.ones((3, 3), np.uint8)
    assert ((cv2.erode(opencv, window) <= ours) & (ours <= cv2.dilate(opencv, window))).all()


def test_a_printable_board_has_the_squares_length_at_the_given_dpi():
    image = calibration.printable_board_image(SPEC, dpi=300, margin=0.01)
    per_square = round(SPEC.square_length / 0.0254 * 300)
    margin = round(0.01 / 0.0254 * 300)
    assert image.shape == (SPEC.squares_y * per_square + 2 * margin, SPEC.squares_x * per_square + 2 * margin)


@pytest.mark.parametrize("kwargs,message", [
    ({"marker_length": 0.05}, "must be smaller than square_length"),
    ({"squares_x": 1}, "at least 2 x 2 squares"),
    ({"square_length": math.nan}, "square_length must be a positive number"),
    ({"marker_length": -0.01}, "marker_length must be a positive number"),
    ({"dictionary": "DICT_9X9_1"}, "unknown ArUco dictionary 'DICT_9X9_1'"),
    ({"squares_x": 12, "squares_y": 11, "dictionary": "DICT_4X4_50"}, "need 66 markers; DICT_4X4_50 has 50"),
])
def test_a_board_that_cannot_be_drawn_or_detected_is_refused(kwargs, message):
    with pytest.raises(CalibrationError, match=message):
        CharucoBoardSpec(**kwargs)


# -------------------------------------------------------------------------------------------- errors
def test_an_image_without_the_board_says_board_not_found():
    with pytest.raises(BoardNotFound, match="no marker of DICT_5X5_100"):
        calibration.calibrate(np.full((HEIGHT, WIDTH), 128, np.uint8), SPEC, INTRINSICS, BOARD_ON_TABLE)


def test_a_board_of_another_dictionary_is_not_found():
    other = CharucoBoardSpec(dictionary="DICT_4X4_50")
    with pytest.raises(BoardNotFound):
        calibration.detect_board(synthetic_view(OVERHEAD), other, INTRINSICS)


def test_a_mostly_covered_board_says_too_few_corners_and_what_to_do():
    image = synthetic_view(OVERHEAD)
    image[:, 300:] = 128  # only the left columns of the board in view: 18 corners
    with pytest.raises(TooFewCorners, match="18 chessboard corners .* at least 30 needed .*show more of the"):
        calibration.detect_board(image, SPEC, INTRINSICS, min_corners=30)


def test_corners_on_one_line_fix_no_pose():
    """Only the two bottom rows of squares in view: their corners form one row."""
    image = synthetic_view(OVERHEAD)
    two_rows_up = np.linalg.inv(OVERHEAD) @ BOARD_ON_TABLE @ np.array([0.0, 2 * SPEC.square_length, 0.0, 1.0])
    row = (K @ two_rows_up[:3])[1] / two_rows_up[2]
    image[:int(row) - 2] = 128
    with pytest.raises(TooFewCorners, match="corners found lie on one line"):
        calibration.detect_board(image, SPEC, INTRINSICS, min_corners=4)


def test_a_board_of_other_squares_is_refused():
    with pytest.raises(TooFewCorners, match="markers were seen but no corner between them"):
        calibration.calibrate(synthetic_view(OVERHEAD), CharucoBoardSpec(squares_x=5, squares_y=5),
                              INTRINSICS, BOARD_ON_TABLE)


@pytest.mark.parametrize("matrix,distortion,model,message", [
    (np.full((3, 3), math.nan), [], "plumb_bob", "non-finite entries"),
    (np.zeros((3, 3)), [], "plumb_bob", "focal lengths must be positive, got fx=0.0"),
    (K, [0.1, math.inf, 0, 0, 0], "plumb_bob", "non-finite coefficients"),
    (K, [0.1, 0, 0, 0], "equidistant", "'equidistant' with non-zero coefficients is not supported"),
    ([1.0, 2.0], [], "plumb_bob", "camera matrix must be 3x3"),
])
def test_unusable_intrinsics_are_refused_naming_the_problem(matrix, distortion, model, message):
    with pytest.raises(InvalidIntrinsics, match=message):
        CameraIntrinsics(matrix, distortion, WIDTH, HEIGHT, model)


def test_a_model_without_coefficients_is_accepted_whatever_its_name():
    assert CameraIntrinsics(K, [0.0] * 5, WIDTH, HEIGHT, "inverse_brown_conrady").distortion.shape == (5,)


def test_intrinsics_of_another_image_size_are_refused():
    small = CameraIntrinsics(K, [], 320, 240)
    with pytest.raises(InvalidIntrinsics, match="camera info is for 320x240 images, the image is 640x480"):
        calibration.calibrate(synthetic_view(OVERHEAD), SPEC, small, BOARD_ON_TABLE)


def test_a_non_finite_board_pose_is_refused():
    with pytest.raises(CalibrationError, match="non-finite pose"):
        calibration.board_pose_on_table((0.3, math.nan, 0.0))


def test_camera_info_reads_from_both_yaml_forms(tmp_path):
    parsers = tmp_path / "parsers.yaml"
    parsers.write_text("image_width: 640\nimage_height: 480\ncamera_name: color\n"
                       f"camera_matrix: {{rows: 3, cols: 3, data: {K.ravel().tolist()}}}\n"
                       "distortion_model: plumb_bob\n"
                       "distortion_coefficients: {rows: 1, cols: 5, data: [0.01, 0, 0, 0, 0]}\n")
    echo = tmp_path / "echo.yaml"
    echo.write_text("header:\n  frame_id: camera_color_optical_frame\nheight: 480\nwidth: 640\n"
                    "distortion_model: plumb_bob\nd: [0.01, 0.0, 0.0, 0.0, 0.0]\n"
                    f"k: {K.ravel().tolist()}\n---\n")
    for path in (parsers, echo):
        intrinsics = CameraIntrinsics.from_yaml_file(path)
        assert intrinsics.matrix == pytest.approx(K) and intrinsics.distortion[0] == 0.01
        assert (intrinsics.width, intrinsics.height) == (640, 480)


def test_camera_info_without_a_matrix_is_refused(tmp_path):
    path = tmp_path / "info.yaml"
    path.write_text("width: 640\nheight: 480\n")
    with pytest.raises(InvalidIntrinsics, match="neither camera_matrix nor k"):
        CameraIntrinsics.from_yaml_file(path)


# ---------------------------------------------------------------------------------- the calibration file
def a_calibration() -> calibration.CameraCalibration:
    return calibration.calibrate(synthetic_view(CAMERA_POSES["tilted_from_the_front"]), SPEC, INTRINSICS,
                                 BOARD_ON_TABLE)


def test_the_written_file_reads_back_and_says_when_how_and_how_well(tmp_path):
    result = a_calibration()
    path = calibration.write_calibration_file(tmp_path / "camera_calibration.yaml", result, note="bench A")
    position, orientation = calibration.read_calibration_file(path)
    assert position == pytest.approx(result.position, abs=1e-6)
    assert orientation == pytest.approx(result.orientation, abs=1e-7)
    text = path.read_text()
    assert f"# Measured: {result.measured}" in text and result.measured.startswith("20")
    assert f"# Board: {SPEC.describe()}" in text
    assert f"# Reprojection error: {result.rms_px:.3f} px RMS" in text
    assert "# bench A" in text and text.count("/**:") == 1


def test_the_file_is_a_ros_parameter_file_for_every_node(tmp_path):
    import yaml

    path = calibration.write_calibration_file(tmp_path / "c.yaml", a_calibration())
    parameters = yaml.safe_load(path.read_text())["/**"]["ros__parameters"]
    assert set(parameters) == {"camera_position", "camera_orientation"}
    assert all(isinstance(v, float) for v in parameters["camera_position"] + parameters["camera_orientation"])


def test_the_shipped_calibration_file_holds_the_simulated_cameras_pose():
    import pathlib

    shipped = pathlib.Path(__file__).resolve().parents[3] / calibration.CALIBRATION_FILE
    position, orientation = calibration.read_calibration_file(shipped)
    assert position == pytest.approx(cell.CAMERA_POSITION)
    assert orientation == pytest.approx(cell.CAMERA_ORIENTATION)


def parameters_as_rcl_reads_them(path, node_name: str) -> tuple:
    """camera_position and camera_orientation as a node `node_name` started with --params-file gets them."""
    import rclpy
    from parameter_files import as_declared

    values = as_declared(rclpy.get_default_context(), node_name, ["--ros-args", "--params-file", str(path)],
                         {"camera_position": [0.0] * 3, "camera_orientation": [0.0] * 4})
    return tuple(tuple(value) for value in values.values())


@pytest.mark.usefixtures("rcl_context")
@pytest.mark.parametrize("node_name", ["heightmap", "sim_cell"])
def test_rcl_reads_the_written_file_as_double_arrays_for_every_node(tmp_path, node_name):
    result = a_calibration()
    path = calibration.write_calibration_file(tmp_path / "camera_calibration.yaml", result)
    position, orientation = parameters_as_rcl_reads_them(path, node_name)
    assert position == pytest.approx(result.position, abs=1e-6)
    assert orientation == pytest.approx(result.orientation, abs=1e-7)


@pytest.mark.usefixtures("rcl_context")
def test_rcl_reads_the_shipped_file():
    import pathlib

    shipped = pathlib.Path(__file__).resolve().parents[3] / calibration.CALIBRATION_FILE
    assert parameters_as_rcl_reads_them(shipped, "heightmap") == (tuple(cell.CAMERA_POSITION),
                                                                 tuple(cell.CAMERA_ORIENTATION))


def test_writing_into_a_missing_directory_says_where_to_run_from(tmp_path):
    with pytest.raises(CalibrationFileError, match="does not exist .*repository root"):
        calibration.write_calibration_file(tmp_path / "no" / "c.yaml", a_calibration())


def parameter_file(position="[0.5, 0, 0.75]", orientation="[1, 0, 0, 0]", section="/**") -> str:
    text = f"{section}:\n  ros__parameters:\n"
    if position is not None:
        text += f"    camera_position: {position}\n"
    if orientation is not None:
        text += f"    camera_orientation: {orientation}\n"
    return text


@pytest.mark.parametrize("text,message", [
    ("camera_position: [", "is not YAML"),
    ("- 1\n- 2\n", "holds no ROS parameter sections"),
    (parameter_file(orientation=None), "has no section with ros__parameters"),
    (parameter_file(position="[0.5, 0.75]"), "camera_position must be a list of 3 numbers"),
    (parameter_file(position="[0.5, .nan, 0.75]"), "camera_position has non-finite values"),
    (parameter_file(orientation="[1, 0, 0, 1]"), "has norm 1.414214, not 1"),
    (parameter_file(section="a") + parameter_file(section="b"),
     "several sections \\['a', 'b'\\] and none is /"),
])
def test_a_file_without_a_usable_camera_pose_is_refused_naming_the_problem(text, message):
    with pytest.raises(CalibrationFileError, match=message):
        calibration.read_calibration_text(text, "test.yaml")


def test_a_missing_file_is_refused_naming_it(tmp_path):
    with pytest.raises(CalibrationFileError, match="cannot read the calibration file .*missing.yaml"):
        calibration.read_calibration_file(tmp_path / "missing.yaml")


def test_a_nearly_unit_quaternion_is_normalised_and_a_node_section_is_read():
    text = parameter_file(orientation="[1.0004, 0, 0, 0]", section="heightmap")
    _, orientation = calibration.read_calibration_text(text)
    assert orientation == pytest.approx((1.0, 0.0, 0.0, 0.0))


def test_pose_and_quaternion_convert_both_ways():
    quaternion = Rotation.from_euler("xyz", [0.3, -0.2, 1.1]).as_quat(canonical=True)
    position, back = calibration.position_and_quaternion(calibration.pose_matrix((1, 2, 3), quaternion))
    assert position == pytest.approx((1, 2, 3)) and back == pytest.approx(quaternion)
