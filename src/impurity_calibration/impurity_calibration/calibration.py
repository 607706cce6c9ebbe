"""Camera pose from a ChArUco board, and THE calibration file that holds it (pure: no rclpy).

The camera's pose in the cell is `camera_color_optical_frame` in `base_link`. A ChArUco board (a
chessboard whose white squares hold ArUco markers, OpenCV's aruco module) lies at a measured place on
the table; one colour image with the camera's intrinsics gives the board's pose in the camera
(`cv2.solvePnP` on the board's chessboard corners, IPPE for planar targets, then Levenberg-Marquardt
refinement), and the camera's pose in base_link follows:

    T_base_camera = T_base_board @ inv(T_camera_board)

The board frame (what `board_pose_on_table` places on the table). Hold the printed page upright as
you read it: the origin is the lower-left outer corner of the squares (not of the paper), x runs right
along the bottom row of squares (`squares_x` of them), y up the page (`squares_y` squares), z out of
the printed face. Lying face up on the table at yaw 0, the page's "right" points along +x_base and its
"up" along +y_base: the default overhead camera (image columns along +x_base, rows along -y_base) sees
it upright.
OpenCV's own board frame (origin at the upper-left corner, y down the page, z into the page) is
converted here, once (`board_from_opencv`).

    spec = CharucoBoardSpec()                       # 9 x 7 squares of 40 mm, 30 mm markers, DICT_5X5_100
    image = board_image(spec, pixels_per_square=100) # to print, or to texture the simulator's board
    board = board_pose_on_table((0.32, -0.14, 0.0))  # m: the board's origin corner in base_link, yaw 0
    result = calibrate(color, spec, CameraIntrinsics.from_camera_info(info), board)
    write_calibration_file("bringup/config/camera_calibration.yaml", result)
    position, orientation = read_calibration_file("bringup/config/camera_calibration.yaml")

Units: metres, radians, pixels; quaternions (x, y, z, w). Errors are CalibrationError subclasses whose
text says what to change: BoardNotFound, TooFewCorners, InvalidIntrinsics, CalibrationFileError.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import pathlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from impurity_common import names

DEFAULT_MIN_CORNERS = 6  # chessboard corners: 4 determine a planar pose, 6 give a check on it
# Renders of the simulated camera measure 0.0-0.4 px RMS (docs/calibration.md). Above this the pinhole
# model does not fit the corners: intrinsics of another stream or resolution, distortion left out, a
# board that is not flat, motion blur. (A wrong square length does not show here: it scales the pose.)
REPROJECTION_WARNING_PX = 1.0
BOARD_EDGE_TOLERANCE = 0.005  # m: two touched corners of the board must lie its width apart within this
QUATERNION_NORM_TOLERANCE = 1e-3  # a file's quaternion is renormalised within this, refused beyond
CALIBRATION_FILE = "bringup/config/camera_calibration.yaml"  # relative to the repository root
POSITION_PARAMETER = "camera_position"  # the parameters heightmap_node and sim_cell declare
ORIENTATION_PARAMETER = "camera_orientation"
# Distortion models whose coefficients OpenCV's pinhole model reads as given (k1 k2 p1 p2 [k3 ...]).
OPENCV_DISTORTION_MODELS = ("plumb_bob", "rational_polynomial", "")
# OpenCV's board frame (origin upper-left, y down the page, z into it) -> the board frame above:
# p_board = R p_cv + t with R = diag(1, -1, -1), t = (0, board height, 0): see board_from_opencv().
OPENCV_TO_BOARD_ROTATION = np.diag([1.0, -1.0, -1.0])


class CalibrationError(ValueError):
    """The calibration cannot be made; the text says what to change."""


class BoardNotFound(CalibrationError):
    """No marker of the board's dictionary in the image."""


class TooFewCorners(CalibrationError):
    """Markers were found but too few chessboard corners (or all on one line) to fix a pose."""


class InvalidIntrinsics(CalibrationError):
    """Camera matrix or distortion that cannot be used (non-finite, non-positive, unknown model)."""


class CalibrationFileError(CalibrationError):
    """A calibration file that is missing, unreadable or holds no usable camera pose."""


# ------------------------------------------------------------------------------------------- board
def _dictionary_id(name: str) -> int:
    value = getattr(cv2.aruco, name, None) if name.startswith("DICT_") else None
    if not isinstance(value, int):
        known = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
        raise CalibrationError(f"unknown ArUco dictionary {name!r}; expected one of {known}")
    return value


@dataclass(frozen=True)
class CharucoBoardSpec:
    """A ChArUco board: `squares_x` x `squares_y` squares of `square_length` m, ArUco markers of
    `marker_length` m in the white squares, from the predefined dictionary `dictionary` (a cv2.aruco
    DICT_* name). The default fits an A3 page in landscape (360 mm x 280 mm of squares, 8 mm margins
    top and bottom) and most of the 448 mm workspace: at 0.75 m the RealSense colour stream (fx ~ 618
    px) sees 33 px squares. (An A4 board, 7 x 5 squares of 35 mm, works too; its corners span less
    of the image, so its pose is less certain.) An odd `squares_y` avoids OpenCV's legacy-pattern
    ambiguity of boards with an even number of rows. Raises CalibrationError for a geometry OpenCV
    cannot draw or detect."""

    squares_x: int = 9
    squares_y: int = 7
    square_length: float = 0.040  # m
    marker_length: float = 0.030  # m
    dictionary: str = "DICT_5X5_100"

    def __post_init__(self):
        if int(self.squares_x) < 2 or int(self.squares_y) < 2:
            raise CalibrationError(f"a ChArUco board needs at least 2 x 2 squares, got "
                                   f"{self.squares_x} x {self.squares_y}")
        for label, value in (("square_length", self.square_length), ("marker_length", self.marker_length)):
            if not (math.isfinite(value) and value > 0.0):
                raise CalibrationError(f"{label} must be a positive number of metres, got {value}")
        if self.marker_length >= self.square_length:
            raise CalibrationError(f"marker_length ({self.marker_length} m) must be smaller than "
                                   f"square_length ({self.square_length} m)")
        markers = (self.squares_x * self.squares_y) // 2
        size = cv2.aruco.getPredefinedDictionary(_dictionary_id(self.dictionary)).bytesList.shape[0]
        if markers > size:
            raise CalibrationError(f"{self.squares_x} x {self.squares_y} squares need {markers} markers; "
                                   f"{self.dictionary} has {size}")

    @property
    def width(self) -> float:
        """Extent of the squares along the board's x (m)."""
        return self.squares_x * self.square_length

    @property
    def height(self) -> float:
        """Extent of the squares along the board's y (m)."""
        return self.squares_y * self.square_length

    @property
    def corner_count(self) -> int:
        """Inner chessboard corners: what a full view of the board yields."""
        return (self.squares_x - 1) * (self.squares_y - 1)

    def cv_board(self) -> cv2.aruco.CharucoBoard:
        """The OpenCV board object (its own frame: origin upper-left, y down the page)."""
        dictionary = cv2.aruco.getPredefinedDictionary(_dictionary_id(self.dictionary))
        return cv2.aruco.CharucoBoard((int(self.squares_x), int(self.squares_y)), float(self.square_length),
                                      float(self.marker_length), dictionary)

    def describe(self) -> str:
        return (f"{self.squares_x}x{self.squares_y} squares of {self.square_length * 1000:.1f} mm, markers "
                f"{self.marker_length * 1000:.1f} mm, {self.dictionary}")


def board_image(spec: CharucoBoardSpec, pixels_per_square: int = 100, margin_px: int = 0) -> np.ndarray:
    """The board as a grayscale uint8 image (H, W) = (squares_y, squares_x) * pixels_per_square plus a
    white margin of `margin_px` on every side; one pixel is square_length / pixels_per_square m. Upright
    as printed: row 0 is the top of the page (the board frame's y points to row 0).

    Drawn from OpenCV's board layout (CharucoBoard.getObjPoints, getIds) and marker images
    (aruco.generateImageMarker): the squares' corners fall exactly on pixel boundaries, markers within
    half a pixel. (CharucoBoard.generateImage fails an assertion for some sizes, e.g. 7 x 5 squares of
    100 px with markers at 24/35 of a square, in OpenCV 5.0.0.)"""
    pixels_per_square, margin = int(pixels_per_square), int(margin_px)
    if pixels_per_square < 10:
        raise CalibrationError(f"pixels_per_square must be at least 10 to draw the markers, got "
                               f"{pixels_per_square}")
    if margin < 0:
        raise CalibrationError(f"margin_px must be >= 0, got {margin_px}")
    board = spec.cv_board()
    scale = pixels_per_square / spec.square_length  # px per m
    side = int(round(spec.marker_length * scale))
    image = np.zeros((spec.squares_y * pixels_per_square, spec.squares_x * pixels_per_square), np.uint8)
    white_squares = set()
    for corners, marker_id in zip(board.getObjPoints(), np.asarray(board.getIds()).reshape(-1), strict=True):
        corners = np.asarray(corners, dtype=np.float64).reshape(4, 3)
        centre = corners[:, :2].mean(axis=0)
        row, col = int(centre[1] // spec.square_length), int(centre[0] // spec.square_length)
        white_squares.add((row, col))
        image[row * pixels_per_square:(row + 1) * pixels_per_square,
              col * pixels_per_square:(col + 1) * pixels_per_square] = 255
        left, top = (int(round(v * scale)) for v in corners[0, :2])  # corner 0: the marker's top-left
        image[top:top + side, left:left + side] = cv2.aruco.generateImageMarker(
            board.getDictionary(), int(marker_id), side, borderBits=1)
    return cv2.copyMakeBorder(image, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255)


def printable_board_image(spec: CharucoBoardSpec, dpi: float = 300.0, margin: float = 0.01) -> np.ndarray:
    """The board to print at `dpi` (dots per inch) at 100 % scale, with a white margin of `margin` m.
    Pixels per square are rounded, so the printed square differs from square_length by less than one
    dot (0.085 mm at 300 dpi); measure the printed squares and markers and give what you measured."""
    if not (math.isfinite(dpi) and dpi >= 72.0):
        raise CalibrationError(f"dpi must be at least 72, got {dpi}")
    per_metre = dpi / 0.0254
    return board_image(spec, max(10, round(spec.square_length * per_metre)), round(margin * per_metre))


def board_from_opencv(spec: CharucoBoardSpec) -> np.ndarray:
    """4x4 T_board_opencvboard: points of OpenCV's board frame (origin upper-left corner, y down the
    page, z into it) in the board frame of this module (origin lower-left, y up, z out of the face)."""
    transform = np.eye(4)
    transform[:3, :3] = OPENCV_TO_BOARD_ROTATION
    transform[:3, 3] = (0.0, spec.height, 0.0)
    return transform


# -------------------------------------------------------------------------------------- intrinsics
@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics: `matrix` K (3x3, px), `distortion` coefficients (OpenCV order k1 k2 p1 p2
    [k3 ...], may be empty), image `width` x `height` (px, 0 = not known), `distortion_model` as in
    sensor_msgs/CameraInfo. Raises InvalidIntrinsics for non-finite or non-positive focal lengths, a
    non-finite coefficient, or non-zero coefficients of a model OpenCV's pinhole model cannot apply."""

    matrix: np.ndarray
    distortion: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    width: int = 0
    height: int = 0
    distortion_model: str = "plumb_bob"

    def __post_init__(self):
        try:
            matrix = np.asarray(self.matrix, dtype=np.float64).reshape(3, 3)
            distortion = np.asarray(self.distortion, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError) as error:
            raise InvalidIntrinsics(f"camera matrix must be 3x3 numbers and distortion a list of numbers "
                                    f"({error})") from None
        if not np.all(np.isfinite(matrix)):
            raise InvalidIntrinsics(f"camera matrix has non-finite entries: {matrix.ravel().tolist()}")
        if matrix[0, 0] <= 0.0 or matrix[1, 1] <= 0.0:
            raise InvalidIntrinsics(f"focal lengths must be positive, got fx={matrix[0, 0]}, "
                                    f"fy={matrix[1, 1]}"
                                    " (is camera_info filled in? an uncalibrated camera publishes zeros)")
        if not np.all(np.isfinite(distortion)):
            raise InvalidIntrinsics(f"distortion has non-finite coefficients: {distortion.tolist()}")
        if self.distortion_model not in OPENCV_DISTORTION_MODELS and np.any(distortion != 0.0):
            raise InvalidIntrinsics(
                f"distortion model {self.distortion_model!r} with non-zero coefficients is not supported "
                f"(supported: plumb_bob, rational_polynomial); rectify the image first (image_proc) or use "
                f"a stream without distortion (RealSense colour streams publish zeros)")
        object.__setattr__(self, "matrix", matrix)
        object.__setattr__(self, "distortion", distortion)

    @classmethod
    def from_camera_info(cls, info) -> CameraIntrinsics:
        """From a sensor_msgs/CameraInfo (or anything with its fields k, d, width, height,
        distortion_model)."""
        return cls(matrix=np.asarray(info.k, dtype=np.float64),
                   distortion=np.asarray(info.d, dtype=np.float64),
                   width=int(info.width), height=int(info.height),
                   distortion_model=str(info.distortion_model))

    @classmethod
    def from_mapping(cls, data: Mapping) -> CameraIntrinsics:
        """From a parsed YAML: the camera_calibration_parsers format (`camera_matrix: {data: [...]}`,
        `distortion_coefficients`, `image_width`, `image_height`, `distortion_model`) or what
        `ros2 topic echo --once .../camera_info` prints (`k`, `d`, `width`, `height`)."""
        if not isinstance(data, Mapping):
            raise InvalidIntrinsics(f"camera info must be a mapping, got {type(data).__name__}")

        def values(entry):
            return entry.get("data") if isinstance(entry, Mapping) else entry

        if "camera_matrix" in data:
            matrix = values(data["camera_matrix"])
            distortion = values(data.get("distortion_coefficients", []))
            width, height = data.get("image_width", 0), data.get("image_height", 0)
        elif "k" in data:
            matrix, distortion = data["k"], data.get("d", [])
            width, height = data.get("width", 0), data.get("height", 0)
        else:
            raise InvalidIntrinsics(f"camera info has neither camera_matrix nor k (keys: {sorted(data)})")
        return cls(matrix=matrix, distortion=distortion if distortion is not None else [],
                   width=int(width or 0), height=int(height or 0),
                   distortion_model=str(data.get("distortion_model", "plumb_bob") or ""))

    @classmethod
    def from_yaml_file(cls, path) -> CameraIntrinsics:
        """From a camera info YAML file (see from_mapping); the first document of several."""
        try:
            documents = list(yaml.safe_load_all(pathlib.Path(path).read_text()))
        except (OSError, yaml.YAMLError) as error:
            raise InvalidIntrinsics(f"cannot read camera info {path}: {error}") from None
        documents = [d for d in documents if d is not None]
        if not documents:
            raise InvalidIntrinsics(f"camera info {path} is empty")
        return cls.from_mapping(documents[0])


# ----------------------------------------------------------------------------------------- detection
@dataclass
class BoardDetection:
    """Chessboard corners of the board found in an image: `corners` (N, 2) px, `ids` (N,) corner ids of
    the board, `marker_count` ArUco markers of the board found."""

    corners: np.ndarray
    ids: np.ndarray
    marker_count: int


def _gray(image: np.ndarray) -> np.ndarray:
    array = np.asarray(image)
    if array.dtype != np.uint8 or array.ndim not in (2, 3) or array.size == 0:
        raise CalibrationError(f"expected a uint8 image (H, W) or (H, W, 3|4), got {array.dtype} "
                               f"{array.shape}")
    if array.ndim == 2:
        return array
    if array.shape[2] == 3:
        return cv2.cvtColor(array, cv2.COLOR_RGB2GRAY)
    if array.shape[2] == 4:
        return cv2.cvtColor(array, cv2.COLOR_RGBA2GRAY)
    raise CalibrationError(f"expected 1, 3 or 4 channels, got {array.shape[2]}")


def detect_board(image: np.ndarray, spec: CharucoBoardSpec, intrinsics: CameraIntrinsics | None = None,
                 min_corners: int = DEFAULT_MIN_CORNERS) -> BoardDetection:
    """Find the board's chessboard corners (sub-pixel) in an RGB, RGBA or grayscale uint8 image.

    Raises BoardNotFound when no marker of the board is seen, TooFewCorners when fewer than
    `min_corners` corners (at least 4) are found or they all lie on one line."""
    gray = _gray(image)
    board = spec.cv_board()
    charuco_parameters = cv2.aruco.CharucoParameters()
    if intrinsics is not None:
        charuco_parameters.cameraMatrix = intrinsics.matrix
        charuco_parameters.distCoeffs = intrinsics.distortion
    detector_parameters = cv2.aruco.DetectorParameters()
    detector_parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.CharucoDetector(board, charuco_parameters, detector_parameters)
    corners, ids, _, marker_ids = detector.detectBoard(gray)
    markers = 0 if marker_ids is None else int(len(marker_ids))
    found = 0 if ids is None else int(len(ids))
    if markers == 0:
        raise BoardNotFound(
            f"no marker of {spec.dictionary} in the {gray.shape[1]}x{gray.shape[0]} image: is the whole "
            f"board in view, in focus, lit evenly without glare, and does the dictionary match the printed "
            f"board?")
    required = max(4, int(min_corners))
    if found < required:
        hint = ("markers were seen but no corner between them: do the squares and the dictionary match the "
                "printed board?" if found == 0 and markers >= 4 else
                "show more of the board, bring the camera closer or light the board evenly")
        raise TooFewCorners(f"{found} chessboard corners found from {markers} markers, at least {required} "
                            f"needed (a full view has {spec.corner_count}): {hint}")
    ids = ids.reshape(-1).astype(np.int32)
    if board.checkCharucoCornersCollinear(ids):
        raise TooFewCorners(f"the {found} corners found lie on one line: no pose follows; show more rows of "
                            f"the board")
    return BoardDetection(corners=corners.reshape(-1, 2).astype(np.float64), ids=ids, marker_count=markers)


# -------------------------------------------------------------------------------------------- pose
@dataclass
class BoardPose:
    """The board in the camera: `camera_from_board` 4x4 T_camera_board (board frame of this module,
    m), the reprojection error of its corners (`rms_px`, `max_px`) and how many corners fixed it."""

    camera_from_board: np.ndarray
    rms_px: float
    max_px: float
    corner_count: int


def estimate_board_pose(detection: BoardDetection, spec: CharucoBoardSpec,
                        intrinsics: CameraIntrinsics) -> BoardPose:
    """solvePnP of the detected corners and the reprojection error (px) of every corner under the pose.
    IPPE (Collins and Bartoli, "Infinitesimal Plane-Based Pose Estimation", IJCV 2014) solves the
    planar case in closed form; Levenberg-Marquardt (cv2.solvePnPRefineLM) then minimises the
    reprojection error. Raises TooFewCorners (fewer than 4 matched), CalibrationError (no pose)."""
    object_points, image_points = spec.cv_board().matchImagePoints(
        detection.corners.reshape(-1, 1, 2).astype(np.float32), detection.ids)
    object_points = object_points.reshape(-1, 3).astype(np.float64)
    image_points = image_points.reshape(-1, 2).astype(np.float64)
    if len(object_points) < 4:
        raise TooFewCorners(f"only {len(object_points)} corners match the board, at least 4 needed")
    ok, rvec, tvec = cv2.solvePnP(object_points, image_points, intrinsics.matrix, intrinsics.distortion,
                                  flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        raise CalibrationError("solvePnP found no pose for the detected corners")
    rvec, tvec = cv2.solvePnPRefineLM(object_points, image_points, intrinsics.matrix, intrinsics.distortion,
                                      rvec, tvec)
    projected, _ = cv2.projectPoints(object_points, rvec, tvec, intrinsics.matrix, intrinsics.distortion)
    residuals = np.linalg.norm(projected.reshape(-1, 2) - image_points, axis=1)
    camera_from_cv = np.eye(4)
    camera_from_cv[:3, :3] = cv2.Rodrigues(rvec)[0]
    camera_from_cv[:3, 3] = tvec.reshape(3)
    camera_from_board = camera_from_cv @ np.linalg.inv(board_from_opencv(spec))
    return BoardPose(camera_from_board=camera_from_board, rms_px=float(np.sqrt(np.mean(residuals ** 2))),
                     max_px=float(residuals.max()), corner_count=len(object_points))


def pose_matrix(position: Sequence[float], orientation: Sequence[float]) -> np.ndarray:
    """4x4 transform from a position (m) and a quaternion (x, y, z, w; normalised here). Raises
    CalibrationError for non-finite values or a zero quaternion."""
    position = np.asarray(position, dtype=np.float64).reshape(-1)
    orientation = np.asarray(orientation, dtype=np.float64).reshape(-1)
    if position.size != 3 or orientation.size != 4:
        raise CalibrationError(f"a pose needs 3 position values and 4 quaternion values, got "
                               f"{position.size} and {orientation.size}")
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(orientation))):
        raise CalibrationError(f"non-finite pose: position {position.tolist()}, orientation "
                               f"{orientation.tolist()}")
    if np.linalg.norm(orientation) < 1e-9:
        raise CalibrationError("quaternion [0, 0, 0, 0] is no rotation")
    transform = np.eye(4)
    transform[:3, :3] = Rotation.from_quat(orientation).as_matrix()
    transform[:3, 3] = position
    return transform


def board_pose_on_table(position: Sequence[float], yaw: float = 0.0) -> np.ndarray:
    """T_base_board of a board lying face up: its origin (lower-left outer corner of the squares) at
    `position` (m, base_link; z = the table top plus the board's thickness) and its x turned `yaw` rad
    about +z_base from +x_base."""
    if not math.isfinite(yaw):
        raise CalibrationError(f"board yaw must be finite, got {yaw}")
    return pose_matrix(position, Rotation.from_euler("z", yaw).as_quat())


def board_yaw_from_points(origin: Sequence[float], x_point: Sequence[float], spec: CharucoBoardSpec,
                          tolerance: float = BOARD_EDGE_TOLERANCE) -> float:
    """Yaw (rad) of a board lying face up from two touched points (m, base_link): its origin and the
    outer corner at the other end of its bottom row of squares (spec.width along the board's x).
    Touching both with the robot's tool tip measures the board where the camera's pose is wanted: in
    the robot's frame. Raises CalibrationError when the points lie closer together or further apart
    than spec.width by more than `tolerance` m (another corner touched, or another board)."""
    origin, x_point = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (origin, x_point))
    if origin.size != 3 or x_point.size != 3 or not np.all(np.isfinite(np.r_[origin, x_point])):
        raise CalibrationError(f"two finite points [x, y, z] are needed, got {origin.tolist()}, "
                               f"{x_point.tolist()}")
    edge = float(np.linalg.norm((x_point - origin)[:2]))
    if abs(edge - spec.width) > tolerance:
        raise CalibrationError(
            f"the two points lie {edge * 1000:.1f} mm apart on the table, the squares' bottom edge is "
            f"{spec.width * 1000:.1f} mm ({spec.squares_x} squares of {spec.square_length * 1000:.1f} mm): "
            f"touch the outer corners of the bottom row of squares, or give the board's geometry")
    return math.atan2(x_point[1] - origin[1], x_point[0] - origin[0])


def position_and_quaternion(transform: np.ndarray) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(position (m), quaternion (x, y, z, w) with w >= 0) of a 4x4 transform."""
    transform = np.asarray(transform, dtype=np.float64)
    quaternion = Rotation.from_matrix(transform[:3, :3]).as_quat(canonical=True)
    return tuple(float(v) for v in transform[:3, 3]), tuple(float(v) for v in quaternion)


def pose_difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(distance between the origins in m, angle of the relative rotation in degrees) of two 4x4 poses."""
    distance = float(np.linalg.norm(np.asarray(a)[:3, 3] - np.asarray(b)[:3, 3]))
    relative = np.asarray(a)[:3, :3].T @ np.asarray(b)[:3, :3]
    angle = math.degrees(Rotation.from_matrix(relative).magnitude())
    return distance, float(angle)


# ------------------------------------------------------------------------------------- calibration
@dataclass
class CameraCalibration:
    """The camera's optical frame in base_link and how it was found: `position` (m), `orientation`
    (quaternion x, y, z, w), reprojection error (px, RMS and largest), corners used, the board,
    where the board lay (`board_position` m, `board_yaw` rad, or None), `measured` (UTC ISO time)
    and `method` (one line: what measured it)."""

    position: tuple[float, ...]
    orientation: tuple[float, ...]
    rms_px: float
    max_px: float
    corner_count: int
    board: CharucoBoardSpec
    board_position: tuple[float, ...] | None = None
    board_yaw: float | None = None
    measured: str = ""
    method: str = "calibrate_camera (ChArUco board, impurity_calibration.calibration)"
    frames: int = 1
    spread_mm: float = 0.0  # largest distance of a frame's camera position from the combined one
    spread_deg: float = 0.0  # largest angle of a frame's camera orientation from the combined one

    @property
    def pose(self) -> np.ndarray:
        """4x4 T_base_camera."""
        return pose_matrix(self.position, self.orientation)


def _utc_now() -> str:
    return datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def calibrate(image: np.ndarray, spec: CharucoBoardSpec, intrinsics: CameraIntrinsics,
              base_from_board: np.ndarray, min_corners: int = DEFAULT_MIN_CORNERS) -> CameraCalibration:
    """The camera pose in base_link from one image of the board lying at `base_from_board` (4x4
    T_base_board, e.g. board_pose_on_table). Raises BoardNotFound, TooFewCorners, InvalidIntrinsics
    (intrinsics whose image size differs from the image's), CalibrationError."""
    gray = _gray(image)
    if intrinsics.width and intrinsics.height and (intrinsics.width, intrinsics.height) != (
            gray.shape[1], gray.shape[0]):
        raise InvalidIntrinsics(f"camera info is for {intrinsics.width}x{intrinsics.height} images, the "
                                f"image is {gray.shape[1]}x{gray.shape[0]}: use the camera_info of the same "
                                f"stream")
    base_from_board = np.asarray(base_from_board, dtype=np.float64)
    if base_from_board.shape != (4, 4) or not np.all(np.isfinite(base_from_board)):
        raise CalibrationError("the board pose must be a finite 4x4 transform")
    board_pose = estimate_board_pose(detect_board(gray, spec, intrinsics, min_corners), spec, intrinsics)
    base_from_camera = base_from_board @ np.linalg.inv(board_pose.camera_from_board)
    position, orientation = position_and_quaternion(base_from_camera)
    board_position, _ = position_and_quaternion(base_from_board)
    board_yaw = math.atan2(base_from_board[1, 0], base_from_board[0, 0])
    return CameraCalibration(position=position, orientation=orientation, rms_px=board_pose.rms_px,
                             max_px=board_pose.max_px, corner_count=board_pose.corner_count, board=spec,
                             board_position=board_position, board_yaw=board_yaw, measured=_utc_now())


def combine(calibrations: Sequence[CameraCalibration]) -> CameraCalibration:
    """One calibration from several frames of a still camera: the mean position, the mean rotation
    (scipy's chordal mean), the worst reprojection error, and how far the frames spread around it."""
    if not calibrations:
        raise CalibrationError("no calibration to combine")
    positions = np.array([c.position for c in calibrations])
    rotations = Rotation.from_quat(np.array([c.orientation for c in calibrations]))
    mean_rotation = rotations.mean()
    position = positions.mean(axis=0)
    spread_mm = float(np.linalg.norm(positions - position, axis=1).max() * 1000.0)
    spread_deg = float(np.degrees((mean_rotation.inv() * rotations).magnitude()).max())
    first = calibrations[0]
    return dataclasses.replace(
        first, position=tuple(float(v) for v in position),
        orientation=tuple(float(v) for v in mean_rotation.as_quat(canonical=True)),
        rms_px=max(c.rms_px for c in calibrations), max_px=max(c.max_px for c in calibrations),
        corner_count=min(c.corner_count for c in calibrations), frames=len(calibrations),
        spread_mm=spread_mm, spread_deg=spread_deg)


def summary(calibration: CameraCalibration) -> str:
    """Lines a user reads: the pose, the reprojection error, and a warning when it is large."""
    c = calibration
    position = ", ".join(f"{v:.4f}" for v in c.position)
    orientation = ", ".join(f"{v:.5f}" for v in c.orientation)
    lines = [f"camera {names.CAMERA_OPTICAL_FRAME} in {names.BASE_FRAME}:",
             f"  camera_position: [{position}]  # m",
             f"  camera_orientation: [{orientation}]  # quaternion x, y, z, w",
             f"reprojection error {c.rms_px:.3f} px RMS, {c.max_px:.3f} px max, {c.corner_count} corners"
             + (f", {c.frames} frames within {c.spread_mm:.2f} mm and {c.spread_deg:.3f} deg" if c.frames > 1
                else "")]
    if c.rms_px > REPROJECTION_WARNING_PX:
        lines.append(f"WARNING: reprojection error above {REPROJECTION_WARNING_PX} px: check the camera's "
                     "intrinsics (the camera_info of this stream and resolution), that the board lies flat "
                     "and the camera stands still")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------- the calibration file
def calibration_file_text(calibration: CameraCalibration, note: str = "") -> str:
    """The ROS parameter YAML for every node (`/**`) with camera_position and camera_orientation, under
    a header saying when and how it was measured, on which board, and the reprojection error."""
    c = calibration
    board_place = ""
    if c.board_position is not None:
        board_place = (f"# Board origin (lower-left outer corner of the squares) at "
                       f"[{', '.join(f'{v:.4f}' for v in c.board_position)}] m in {names.BASE_FRAME}, yaw "
                       f"{c.board_yaw or 0.0:.4f} rad.\n")
    spread = (f"# {c.frames} frames, within {c.spread_mm:.2f} mm and {c.spread_deg:.3f} deg of the mean.\n"
              if c.frames > 1 else "")
    notes = "".join(f"# {line}\n" if line else "#\n" for line in note.splitlines())
    position = ", ".join(f"{v:.6f}" for v in c.position)
    orientation = ", ".join(f"{v:.8f}" for v in c.orientation)
    return (
        f"# Camera calibration: {names.CAMERA_OPTICAL_FRAME} in {names.BASE_FRAME}, read by heightmap_node\n"
        "# and sim_cell (--params-file) and published as TF. Written by impurity_calibration.calibration;\n"
        "# re-measure with `calibrate_camera` whenever the camera or its mount moves.\n"
        f"# Measured: {c.measured or 'unknown'} by {c.method}\n"
        f"# Board: {c.board.describe()}\n"
        f"{board_place}"
        f"# Reprojection error: {c.rms_px:.3f} px RMS, {c.max_px:.3f} px max over {c.corner_count} corners.\n"
        f"{spread}{notes}"
        "/**:\n"
        "  ros__parameters:\n"
        f"    {POSITION_PARAMETER}: [{position}]  # m, {names.CAMERA_OPTICAL_FRAME} in {names.BASE_FRAME}\n"
        f"    {ORIENTATION_PARAMETER}: [{orientation}]  # quaternion x, y, z, w\n")


def write_calibration_file(path, calibration: CameraCalibration, note: str = "") -> pathlib.Path:
    """Write the calibration file (calibration_file_text) atomically; returns its path. Raises
    CalibrationFileError when the directory does not exist."""
    path = pathlib.Path(path)
    if not path.parent.is_dir():
        raise CalibrationFileError(f"cannot write {path}: directory {path.parent} does not exist (run from "
                                   f"the repository root, or give the output path)")
    text = calibration_file_text(calibration, note)
    read_calibration_text(text, str(path))  # never write a file that would not read back
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(text)
    temporary.replace(path)
    return path


def read_calibration_text(text: str, source: str = "calibration"
                          ) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(camera_position (m), camera_orientation (x, y, z, w), unit norm) from a ROS parameter YAML: the
    `/**` section, else the only node section that sets both. Raises CalibrationFileError naming the
    problem (not YAML, no section with both parameters, wrong lengths, non-finite values, a quaternion
    far from unit norm)."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise CalibrationFileError(f"{source} is not YAML: {error}") from None
    if not isinstance(data, Mapping):
        raise CalibrationFileError(f"{source} holds no ROS parameter sections")
    sections = {}
    for node, content in data.items():
        parameters = content.get("ros__parameters") if isinstance(content, Mapping) else None
        if isinstance(parameters, Mapping) and POSITION_PARAMETER in parameters and \
                ORIENTATION_PARAMETER in parameters:
            sections[str(node)] = parameters
    if not sections:
        raise CalibrationFileError(f"{source} has no section with ros__parameters {POSITION_PARAMETER} and "
                                   f"{ORIENTATION_PARAMETER}")
    if "/**" in sections:
        parameters = sections["/**"]
    elif len(sections) == 1:
        parameters = next(iter(sections.values()))
    else:
        raise CalibrationFileError(f"{source} sets the camera pose in several sections {sorted(sections)} "
                                   f"and none is /**: which one holds?")
    values = {}
    for key, length in ((POSITION_PARAMETER, 3), (ORIENTATION_PARAMETER, 4)):
        entry = parameters[key]
        if not isinstance(entry, list) or len(entry) != length or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in entry):
            raise CalibrationFileError(f"{source}: {key} must be a list of {length} numbers, got {entry!r}")
        if not all(math.isfinite(v) for v in entry):
            raise CalibrationFileError(f"{source}: {key} has non-finite values {entry}")
        values[key] = tuple(float(v) for v in entry)
    quaternion = np.array(values[ORIENTATION_PARAMETER])
    norm = float(np.linalg.norm(quaternion))
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise CalibrationFileError(f"{source}: {ORIENTATION_PARAMETER} {quaternion.tolist()} has norm "
                                   f"{norm:.6f}, "
                                   f"not 1 (x, y, z, w of a unit quaternion)")
    return values[POSITION_PARAMETER], tuple(float(v) for v in quaternion / norm)


def read_calibration_file(path) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(camera_position, camera_orientation) from the calibration file; see read_calibration_text."""
    try:
        text = pathlib.Path(path).read_text()
    except OSError as error:
        raise CalibrationFileError(f"cannot read the calibration file {path}: {error}") from None
    return read_calibration_text(text, str(path))
