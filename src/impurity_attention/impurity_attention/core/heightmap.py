"""RGB-D frame -> orthographic top-down colour and height maps of the workspace (paper section 3).

Every valid depth pixel is back-projected to a 3-D point in `base_link` and dropped straight down
onto a grid over the workspace; a grid cell keeps its highest point (what a camera looking straight
down along gravity would see) and that point's colour. Cells that no pixel reaches (shadows behind
tall objects, depth holes) stay empty: height 0 and black, never a spike; a pixel with a colour and no
depth puts its colour where its ray meets the table plane, on a cell no depth reached, as height unknown
(`Heightmaps.unknown`; NaN in the /heightmap message: core.unknown_height). The same projection carries
any per-pixel label image along (the simulator's segmentation), which is how ground truth reaches
heightmap coordinates.

A camera whose pixels cover more of the table than a cell (`HeightmapProjector.footprint`, e.g.
640x480 at 1.5 m: 2.4 mm per pixel on 2 mm cells) leaves cells between its samples unseen, lines of
them across every object. Those gaps, and only gaps that narrow (`gap_reach` cells, from the
footprint), are filled from the seen cells on both sides of them (`fill_sampling_gaps`): a gap
between two object cells takes the lower of the two, so a gap bordered by table stays table and no
object grows over the table. With pixels finer than the cells (the default camera: 1.2 mm) nothing
is filled and the maps are exactly the projection.

`HeightmapProjector.check_depth` tells whether a frame's depth fits the configured camera pose and
table at all (`depth_problem` words the likely cause): integer depth in other units than
`depth_scale` says (a D405 publishes 0.1 mm), or a wrong camera pose, puts most points far from the
table plane; a camera tilted against its calibration shows a sloped table (`fit_table`, `table_problem`).
`brightness_jump` and `still_scene` tell auto exposure hunting from a scene that moved.

`HeightmapParams` holds every setting of the projection (grid, camera pose, depth units), of pairing colour
and depth frames and of the optional colour adaptation: the heightmap node's parameters of the same names.

`exposure_problem` tells whether the colour heightmap's objects are lit and exposed so that colours can be
compared at all: a channel at the camera's ceiling on most object cells, or objects nearly black.

Pure numpy; no rclpy. One projection of a 640x480 frame takes a few milliseconds because the rays of
a fixed camera are computed once and a cell's maximum uses `np.maximum.at` instead of a sort.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from impurity_common import cell
from impurity_common.colour import SATURATED_SHARE
from impurity_common.grid import MAX_HEIGHT, HeightmapGrid
from impurity_common.parameters import (
    InvalidParameter,
    camera_orientation_param,
    camera_position_param,
    check_fields,
    increasing,
    param,
)

# Depth encodings the camera driver may publish: integer depth in `depth_scale` m per unit (realsense-ros
# 16UC1, millimetres on a D4xx and 0.1 mm on a D405; some drivers say mono16), or 32FC1 metres (sims).
INTEGER_DEPTH_ENCODINGS = ("16UC1", "mono16")
DEPTH_ENCODINGS = (*INTEGER_DEPTH_ENCODINGS, "32FC1")
DEFAULT_DEPTH_SCALE = 0.001  # m per unit of integer depth: RealSense D4xx millimetres
UNSEEN_LABEL = -1  # label of heightmap cells that no pixel reached

# The depth sanity check: a point of a pixel that looks at the workspace is "far" from the table when it
# lies more than this below the table plane, or higher than the grid's max_height; a frame is suspect
# when MOST of them are far, or when fewer than MIN_VALID_FRACTION of those pixels have a depth.
FAR_BELOW_TABLE = 0.05  # m
MOST = 0.5
MIN_VALID_FRACTION = 0.1
# Where the table is (HeightmapProjector.check_depth): the workspace is cut into TABLE_BLOCKS x TABLE_BLOCKS
# blocks; in each, the point at the TABLE_QUANTILE of height (the table wherever a little of it shows
# between the objects) stands for it. The plane through most of those points within TABLE_INLIER (a
# RANSAC over TABLE_TRIALS triples, seeded) is the table, when at least MIN_TABLE_BLOCKS of them lie on it
# (else the table does not show enough to tell). It must lie within TABLE_LIMIT of table_z everywhere over
# the workspace: beyond the occupied height, table reads as object on one side, and thin pieces sink into
# the table on the other (a tilt of 1.5 deg over the 448 mm workspace).
TABLE_BLOCKS = 8
TABLE_QUANTILE = 0.1
TABLE_INLIER = 0.003  # m
TABLE_TRIALS = 200
MIN_TABLE_BLOCKS = 16
TABLE_LIMIT = cell.OCCUPIED_HEIGHT  # m
TABLE_POINTS = 8000  # at most this many depth points (an even subsample) go into the table fit


# Lab statistics (colour_adaptation.lab_statistics) of the seen cells of sim-rendered heightmaps of 70 tuning
# scenes: the reference of the optional sim-to-real colour transfer. Re-measure with
# `python -m impurity_learning.calibrate colour-reference` when the simulator's look changes.
SIM_LAB_MEAN = (60.21, 1.36, -8.57)
SIM_LAB_STD = (9.35, 5.76, 19.01)


@dataclass(frozen=True)
class HeightmapParams:
    """The heightmap's settings: the grid (workspace, resolution, table, max_height), the camera pose and
    depth units it projects with, how colour and depth frames pair, and the optional colour adaptation.
    The heightmap node's parameters of the same names (bringup/config/cell.yaml, section heightmap)."""

    camera_position: tuple[float, ...] = camera_position_param()
    camera_orientation: tuple[float, ...] = camera_orientation_param()
    workspace_x: tuple[float, ...] = param(cell.WORKSPACE_X, "[x_min, x_max] in base_link (m)",
                                           length=2, low=-5.0, high=5.0, check=increasing)
    workspace_y: tuple[float, ...] = param(cell.WORKSPACE_Y, "[y_min, y_max] in base_link (m)",
                                           length=2, low=-5.0, high=5.0, check=increasing)
    resolution: float = param(cell.HEIGHTMAP_RESOLUTION, "Heightmap cell size (m)", low=0.0005, high=0.05)
    table_z: float = param(cell.TABLE_Z, "Table top height in base_link (m)", low=-5.0, high=5.0)
    max_height: float = param(MAX_HEIGHT, "Points higher than this above the table are dropped (arm, "
                              "gripper, noise) (m)", low=0.001, high=5.0)
    sync_tolerance: float = param(0.0, "Largest stamp difference (s) for a colour and a depth frame to pair; "
                                  "0.0 = automatic: half the frame period measured from the stamps (any "
                                  "colour-depth offset of the driver below half a period)", low=0.0, high=1.0)
    depth_offset: float = param(0.0, "s by which the camera driver stamps a depth frame after the colour "
                                "frame it was taken with; taken off depth stamps before pairing (an offset "
                                "near a frame period otherwise pairs each colour frame with a neighbouring "
                                "frame's depth)", low=-1.0, high=1.0)
    depth_scale: float = param(DEFAULT_DEPTH_SCALE, "Metres per unit of integer depth (16UC1, mono16); not "
                               "on the topic: RealSense D4xx 0.001 (mm), D405 0.0001. 32FC1 is always metres",
                               low=1e-7, high=1.0)
    colour_adaptation: bool = param(False, "Reinhard Lab transfer of heightmap colours to the sim reference "
                                    "statistics (real cameras)")
    colour_reference_mean: tuple[float, ...] = param(SIM_LAB_MEAN, "Reference Lab mean [L, a, b] for colour "
                                                     "adaptation", length=3, low=-128.0, high=128.0)
    colour_reference_std: tuple[float, ...] = param(SIM_LAB_STD, "Reference Lab standard deviation [L, a, b] "
                                                    "for colour adaptation", length=3, low=0.001, high=128.0)

    def __post_init__(self):
        check_fields(self)
        extent = min(self.workspace_x[1] - self.workspace_x[0], self.workspace_y[1] - self.workspace_y[0])
        if self.resolution > extent:
            raise InvalidParameter("resolution", f"is larger than the workspace ({extent:g} m across)")

    def grid(self) -> HeightmapGrid:
        """The grid the maps are built on (workspace_x, workspace_y, resolution, table_z, max_height)."""
        (x_min, x_max), (y_min, y_max) = self.workspace_x, self.workspace_y
        return HeightmapGrid(x_min=x_min, x_max=x_max, y_min=y_min, y_max=y_max, resolution=self.resolution,
                             table_z=self.table_z, max_height=self.max_height)

    def camera_pose(self) -> np.ndarray:
        """T_base_cameraoptical, 4x4 (camera_position, camera_orientation)."""
        return pose_matrix(self.camera_position, self.camera_orientation)

    def pairing_tolerance_ns(self) -> int | None:
        """sync_tolerance in ns for core.sync.StampPairer; None (automatic) when it is 0."""
        return int(round(self.sync_tolerance * 1e9)) if self.sync_tolerance > 0 else None


class DepthFormatError(ValueError):
    """A depth image that cannot be read as metres."""


@dataclass
class Heightmaps:
    """color: (rows, cols, 3) uint8, black where unseen; height: (rows, cols) float32 m above the
    table, 0 where unseen; seen: bool, cells some pixel reached; labels: int32 per cell (the label of
    the highest point, UNSEEN_LABEL where unseen) when a label image was projected, else None;
    filled: bool, cells no pixel reached that took their values from the seen cells around them
    (sampling gaps of a camera coarser than the cells; never set where `seen`; None: not computed);
    unknown: bool, cells of height unknown - neither seen nor filled, reached by a pixel with a colour and
    no depth (placed where its ray meets the table plane), whose colour the cell takes (core.unknown_height;
    None: not computed)."""

    color: np.ndarray
    height: np.ndarray
    seen: np.ndarray
    labels: np.ndarray | None = None
    filled: np.ndarray | None = None
    unknown: np.ndarray | None = None

    def height_or_unknown(self) -> np.ndarray:
        """The height map as the /heightmap message carries it: NaN on the unknown cells."""
        if self.unknown is None or not self.unknown.any():
            return self.height
        return np.where(self.unknown, np.float32(np.nan), self.height).astype(np.float32)

    @property
    def known(self) -> np.ndarray:
        """Cells with a value: seen, or filled from their neighbours."""
        return self.seen if self.filled is None else self.seen | self.filled


def pose_matrix(position, quaternion_xyzw) -> np.ndarray:
    """(x, y, z) and a unit quaternion (x, y, z, w) -> 4x4 homogeneous transform."""
    qx, qy, qz, qw = (float(v) for v in quaternion_xyzw)
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not math.isfinite(norm) or norm < 1e-9:
        raise ValueError(f"quaternion {tuple(quaternion_xyzw)} has no rotation (norm {norm})")
    qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
    rotation = np.array([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ])
    pose = np.eye(4)
    pose[:3, :3] = rotation
    pose[:3, 3] = [float(v) for v in position]
    return pose


def default_camera_pose() -> np.ndarray:
    """T_base_cameraoptical of the cell's overhead camera (impurity_common.cell)."""
    return pose_matrix(cell.CAMERA_POSITION, cell.CAMERA_ORIENTATION)


def default_intrinsics() -> np.ndarray:
    return np.array([[cell.CAMERA_FX, 0.0, cell.CAMERA_CX],
                     [0.0, cell.CAMERA_FY, cell.CAMERA_CY],
                     [0.0, 0.0, 1.0]])


def depth_to_meters(depth: np.ndarray, encoding: str, depth_scale: float = DEFAULT_DEPTH_SCALE) -> np.ndarray:
    """Integer depth (16UC1, mono16: `depth_scale` m per unit) or 32FC1 (m) -> float32 metres, NaN
    where the camera saw nothing (0, NaN, inf). The scale is not on the topic: a RealSense D4xx
    publishes millimetres (0.001), a D405 0.1 mm (0.0001)."""
    if encoding not in DEPTH_ENCODINGS:
        raise DepthFormatError(f"depth encoding '{encoding}' not accepted (expected one of "
                               f"{list(DEPTH_ENCODINGS)})")
    if depth.ndim != 2:
        raise DepthFormatError(f"depth must be one channel (H, W), got shape {depth.shape}")
    if encoding in INTEGER_DEPTH_ENCODINGS:
        if depth.dtype != np.uint16:
            raise DepthFormatError(f"{encoding} depth must be uint16, got {depth.dtype}")
        if not (math.isfinite(depth_scale) and depth_scale > 0):
            raise DepthFormatError(f"depth_scale {depth_scale} is not usable (expected > 0 m per unit)")
        meters = depth.astype(np.float32) * np.float32(depth_scale)
    else:
        if depth.dtype != np.float32:
            raise DepthFormatError(f"32FC1 depth must be float32, got {depth.dtype}")
        meters = depth.astype(np.float32, copy=True)
    meters[~np.isfinite(meters) | (meters <= 0.0)] = np.nan
    return meters


def validate_intrinsics(intrinsics) -> np.ndarray:
    k = np.asarray(intrinsics, dtype=np.float64).reshape(3, 3)
    if not (np.all(np.isfinite(k)) and k[0, 0] > 0 and k[1, 1] > 0):
        raise ValueError(f"camera intrinsics are not usable (fx, fy must be > 0): {k.tolist()}")
    return k


@dataclass(frozen=True)
class DepthCheck:
    """One frame's depth against the configured geometry (HeightmapProjector.check_depth)."""

    pixels: int  # camera pixels whose ray meets the table plane inside the workspace (configured pose)
    valid: int  # of them, pixels with a depth
    below: float  # fraction of the valid ones lying more than FAR_BELOW_TABLE below the table plane
    above: float  # fraction lying higher than the grid's max_height above it
    depth_ratio: float  # median of measured depth / the table plane's depth along the same ray; NaN: none
    table: TableFit | None = None  # the table plane the depth shows (None: too little table in view)

    @property
    def far(self) -> float:
        """Fraction of the valid points far from where the table and the objects on it can be."""
        return self.below + self.above


@dataclass(frozen=True)
class TableFit:
    """The table plane fitted through a frame's depth points, z = slope_x * x + slope_y * y + offset in
    base_link, heights from table_z (HeightmapProjector.check_depth; module constants TABLE_*)."""

    slope_x: float  # dz/dx
    slope_y: float  # dz/dy
    offset: float  # m: the plane's height above table_z at the workspace's centre
    blocks: int  # workspace blocks whose low point lies on the plane
    deviation: float  # m: the largest |height above table_z| of the plane over the workspace's corners

    @property
    def tilt_deg(self) -> float:
        return math.degrees(math.atan(math.hypot(self.slope_x, self.slope_y)))

    def rising_towards(self) -> str:
        """The base_link direction in which the fitted table rises, e.g. '+x -y'."""
        parts = [f"{'+' if slope > 0 else '-'}{axis}" for axis, slope in (("x", self.slope_x),
                                                                        ("y", self.slope_y))
                 if abs(slope) >= 0.25 * max(abs(self.slope_x), abs(self.slope_y))]
        return " ".join(parts)


def fit_table(x: np.ndarray, y: np.ndarray, z: np.ndarray, grid: HeightmapGrid) -> TableFit | None:
    """The table plane through depth points (x, y in base_link, z above table_z; m) over `grid`'s
    workspace, or None when too little table shows (module constants TABLE_*)."""
    width, depth = grid.x_max - grid.x_min, grid.y_max - grid.y_min
    bx = np.floor((x - grid.x_min) / width * TABLE_BLOCKS).astype(np.int64)
    by = np.floor((y - grid.y_min) / depth * TABLE_BLOCKS).astype(np.int64)
    inside = (bx >= 0) & (bx < TABLE_BLOCKS) & (by >= 0) & (by < TABLE_BLOCKS) & np.isfinite(z)
    x, y, z, block = x[inside], y[inside], z[inside], (by * TABLE_BLOCKS + bx)[inside]
    if len(z) == 0:
        return None
    order = np.lexsort((z, block))  # by block, then by height within it
    counts = np.bincount(block, minlength=TABLE_BLOCKS * TABLE_BLOCKS)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    used = counts >= 20
    low = order[starts[used] + np.floor(TABLE_QUANTILE * (counts[used] - 1)).astype(np.int64)]
    points = np.stack([x[low], y[low], z[low]], axis=1).astype(np.float64)
    if len(points) < MIN_TABLE_BLOCKS:
        return None
    centre = np.array([(grid.x_min + grid.x_max) / 2, (grid.y_min + grid.y_max) / 2, 0.0])
    points -= centre
    design = np.column_stack([points[:, 0], points[:, 1], np.ones(len(points))])
    rng = np.random.default_rng(0)
    triples = np.array([rng.choice(len(points), 3, replace=False) for _ in range(TABLE_TRIALS)])
    systems = design[triples]  # (trials, 3, 3): the plane through each triple
    solvable = np.abs(np.linalg.det(systems)) > 1e-12
    if not solvable.any():
        return None
    planes = np.linalg.solve(systems[solvable], points[triples[solvable], 2][..., None])[..., 0]
    inliers = np.abs(planes @ design.T - points[:, 2]) <= TABLE_INLIER  # (trials, blocks)
    best = inliers[int(np.argmax(inliers.sum(axis=1)))]  # the first of the most supported
    if best.sum() < MIN_TABLE_BLOCKS:
        return None
    (slope_x, slope_y, offset), *_ = np.linalg.lstsq(design[best], points[best, 2], rcond=None)
    corners = [slope_x * dx + slope_y * dy + offset
               for dx in (-width / 2, width / 2) for dy in (-depth / 2, depth / 2)]
    return TableFit(float(slope_x), float(slope_y), float(offset), int(best.sum()),
                    float(max(abs(c) for c in corners)))


def depth_problem(check: DepthCheck, encoding: str = "32FC1", depth_scale: float = DEFAULT_DEPTH_SCALE
                  ) -> str | None:
    """None when the frame's depth fits the camera pose and the table; else one line naming what is
    wrong and the likely causes, with the parameters to change."""
    pose = "the camera pose (camera_position, camera_orientation: the optical frame in base_link)"
    if check.pixels == 0:
        return (f"no camera pixel looks at the workspace from the configured pose: check {pose} against "
                "workspace_x, workspace_y and table_z")
    if check.valid < MIN_VALID_FRACTION * check.pixels:
        return (f"only {check.valid / check.pixels:.0%} of the {check.pixels} pixels that should see the "
                f"workspace have a depth: the camera sees nothing there (covered, out of its range, an empty "
                f"depth stream) or looks elsewhere: check {pose}")
    if check.far <= MOST:
        return table_problem(check.table)
    ratio = check.depth_ratio
    if encoding in INTEGER_DEPTH_ENCODINGS:
        units = (f"the depth units: {encoding} depth is read with depth_scale={depth_scale:g} m per unit "
                 "(RealSense D4xx: 0.001, D405: 0.0001)")
        if math.isfinite(ratio) and ratio > 0:
            units += f"; these depths fit depth_scale={float(f'{depth_scale / ratio:.1g}'):g}"
    else:
        units = f"the depth units: {encoding} depth must be metres"
    # a unit mistake scales every depth by a power of ten; a pose mistake by anything
    decades = math.log10(ratio) if math.isfinite(ratio) and ratio > 0 else 0.0
    units_first = round(decades) != 0 and abs(decades - round(decades)) < 0.1
    causes = f"{units}; or {pose}, or table_z" if units_first else f"{pose}, or table_z; or {units}"
    return (f"{check.far:.0%} of the {check.valid} depth points in the workspace's view lie far from the "
            f"table plane ({check.below:.0%} more than {FAR_BELOW_TABLE * 100:.0f} cm below table_z, "
            f"{check.above:.0%} higher than max_height), at {ratio:.4g} times the table's distance along "
            f"their rays. Likely cause: {causes}")


def table_problem(table: TableFit | None) -> str | None:
    """None when the table the depth shows lies where the configuration says (within TABLE_LIMIT of
    table_z over the workspace), or too little of it shows to tell; else one line saying where it is and
    what to change."""
    if table is None or table.deviation <= TABLE_LIMIT:
        return None
    tilt = table.tilt_deg
    sloped = f"tilted {tilt:.1f} deg (rising towards {table.rising_towards()}), " if tilt >= 0.1 else ""
    return (f"the table the depth shows ({table.blocks} of {TABLE_BLOCKS * TABLE_BLOCKS} workspace blocks) "
            f"lies up to {table.deviation * 1000:.0f} mm from table_z over the workspace ({sloped}"
            f"{table.offset * 1000:+.0f} mm at its centre), beyond {TABLE_LIMIT * 1000:.0f} mm: table would "
            "read as object and thin pieces sink into it. Likely cause: the camera pose (camera_position, "
            "camera_orientation: the optical frame in base_link) does not match the mounted camera - "
            "recalibrate it (hand-eye); or table_z")


# exposure_problem: an 8-bit channel at CLIPPED_LEVEL or more reads the same whatever the light (the
# camera's ceiling); objects at DARK_LEVEL or less in every channel are nearly black. A colour heightmap is
# badly exposed when at least EXPOSURE_SHARE of its object cells are clipped in one channel, or dark: half,
# colour.SATURATED_SHARE's notion of a clipped product. On the first views of 101 tuning palettes it flags
# most scenes of 10 palettes, 2 of the 4 where attention finds fewer than half of the impurities and 5 where
# it finds them all: a warning worth reading, not a verdict.
CLIPPED_LEVEL = 250
DARK_LEVEL = 5
EXPOSURE_SHARE = SATURATED_SHARE
CHANNEL_NAMES = "RGB"


def clipped_channel(colours: np.ndarray) -> tuple:
    """(channel, share) of colours (N, 3) uint8 RGB: the channel (0 R, 1 G, 2 B) in which the largest share
    of them is at CLIPPED_LEVEL or more, and that share; (0, 0.0) for no colours. ValueError for another
    shape or type (a channel-first, RGBA or float image would give a wrong share)."""
    colours = np.asarray(colours)
    if colours.dtype != np.uint8 or colours.ndim != 2 or colours.shape[1] != 3:
        raise ValueError(f"colours must be (N, 3) uint8 RGB, got {colours.shape} {colours.dtype}")
    if not len(colours):
        return 0, 0.0
    shares = np.mean(colours >= CLIPPED_LEVEL, axis=0)
    channel = int(np.argmax(shares))
    return channel, float(shares[channel])


def exposure_problem(color: np.ndarray, height: np.ndarray,
                     min_object_height: float = cell.OCCUPIED_HEIGHT) -> str | None:
    """None when the objects of a colour heightmap (H, W, 3) uint8 RGB, height (H, W) m (cells above
    min_object_height m are objects, as for attention) are exposed well enough to compare colours; else
    one line saying what is wrong, what it costs and which camera parameters to change (module constants
    above)."""
    objects = np.asarray(height) > min_object_height
    if not objects.any():
        return None
    colours = np.asarray(color)[objects]
    channel, share = clipped_channel(colours)
    if share >= EXPOSURE_SHARE:
        return (f"the colour image is clipped ({CLIPPED_LEVEL}+ of 255) in {CHANNEL_NAMES[channel]} on "
                f"{share:.0%} of the object cells: colour differences in that channel are lost, "
                "and an impurity lighter than a light product cannot be seen. Lower the camera's exposure "
                "(realsense-ros: rgb_camera.enable_auto_exposure false, rgb_camera.exposure) or the light")
    dark = float(np.mean(colours.max(axis=1) <= DARK_LEVEL))
    if dark >= EXPOSURE_SHARE:
        return (f"{dark:.0%} of the object cells are nearly black (every channel {DARK_LEVEL} or less of "
                "255): colours cannot be compared there. Raise the camera's exposure or gain (realsense-ros: "
                "rgb_camera.exposure, rgb_camera.gain) or the light")
    return None


# brightness_jump: the mean brightness of consecutive colour frames (every channel, 0-255) of a still scene
# (still_scene) should not change by more than BRIGHTNESS_JUMP of the brighter one and BRIGHTNESS_STEP levels
# at once; auto exposure hunting, or a short exposure beating with mains-powered light, does. A scene that
# moved (the arm crossing the view, a new scene: another palette's table is 25 % brighter) is not judged.
BRIGHTNESS_JUMP = 0.15
BRIGHTNESS_STEP = 8.0
# still_scene: two depth images show the same scene when at most STILL_SHARE of their pixels (every 8th row
# and column) changed depth by more than STILL_DEPTH (5 x a RealSense D435's depth noise at 0.75 m).
STILL_DEPTH = 0.01  # m
STILL_SHARE = 0.01


def depth_sample(depth_m: np.ndarray) -> np.ndarray:
    """Every 8th row and column of a depth image (metres, NaN holes): what still_scene compares."""
    return np.asarray(depth_m)[::8, ::8].copy()


def still_scene(previous: np.ndarray | None, current: np.ndarray) -> bool:
    """Whether two depth_samples show the same scene (module constants STILL_*); False without a previous."""
    if previous is None or previous.shape != current.shape:
        return False
    with np.errstate(invalid="ignore"):
        changed = ~(np.abs(current - previous) <= STILL_DEPTH) & ~(np.isnan(current) & np.isnan(previous))
    return float(np.mean(changed)) <= STILL_SHARE


def mean_brightness(color: np.ndarray) -> float:
    """The mean of every channel of a colour image (H, W, 3) uint8 (every 4th row and column)."""
    return float(np.asarray(color)[::4, ::4].mean())


def brightness_jump(previous: float | None, current: float) -> str | None:
    """None when a frame's mean brightness (mean_brightness) is near the previous frame's (None: the first
    frame); else one line naming the jump and the camera's exposure settings."""
    if previous is None:
        return None
    step = current - previous
    if abs(step) < BRIGHTNESS_STEP or abs(step) < BRIGHTNESS_JUMP * max(previous, current):
        return None
    return (f"the colour image's mean brightness jumped from {previous:.0f} to {current:.0f} of 255 "
            f"({step / max(previous, 1.0):+.0%}) between consecutive frames: the camera's auto exposure is "
            "hunting, or a short exposure beats with mains-powered light, and colours of one view cannot be "
            "compared with the next. Fix the exposure (realsense-ros: rgb_camera.enable_auto_exposure false, "
            "rgb_camera.exposure) and set the power-line frequency to the mains' "
            "(rgb_camera.power_line_frequency: 1 = 50 Hz, 2 = 60 Hz)")


# Along a row and along a column. Not the diagonals: between two objects that meet at a right angle an
# unseen cell of the inner corner lies on a diagonal from one to the other, and would become object.
_DIRECTIONS = ((0, 1), (1, 0))


def _shifted(array: np.ndarray, d_row: int, d_col: int, fill) -> np.ndarray:
    """out[r, c] = array[r + d_row, c + d_col], `fill` where that falls outside."""
    out = np.full_like(array, fill)
    rows, cols = array.shape[:2]
    out[max(-d_row, 0):rows - max(d_row, 0), max(-d_col, 0):cols - max(d_col, 0)] = \
        array[max(d_row, 0):rows - max(-d_row, 0), max(d_col, 0):cols - max(-d_col, 0)]
    return out


def fill_sampling_gaps(maps: Heightmaps, reach: int, passes: int | None = None) -> Heightmaps:
    """Fill, in place, the unseen cells that lie between two known cells at most `reach` cells away on
    opposite sides (along a row or a column): the gaps a camera coarser than the cells leaves between
    its samples. Along each such line the cell takes the LOWER of its two nearest known neighbours
    (height, colour, label): inside an object it is the object, and wherever table borders the gap it
    stays table, so no object grows over the table. Of the two lines the higher such value wins. Later
    passes (`passes`, default reach + 1) reach the cells where unsampled rows cross unsampled columns,
    from the cells earlier passes filled. Holes wider than `reach` (shadows, depth holes) stay unseen.
    Sets maps.filled; returns maps."""
    maps.filled = np.zeros_like(maps.seen)
    for _ in range((reach + 1 if passes is None else passes) if reach >= 1 else 0):
        known = maps.known
        if known.all() or not known.any() or not _fill_pass(maps, known, reach):
            break
    return maps


def _fill_pass(maps: Heightmaps, known: np.ndarray, reach: int) -> bool:
    """One pass of fill_sampling_gaps from the `known` cells; False when it filled nothing."""
    rows, cols = known.shape
    index = np.where(known, np.arange(rows * cols).reshape(rows, cols), -1)
    flat_height = maps.height.reshape(-1)
    best_height = np.full((rows, cols), -np.inf, dtype=np.float32)
    best_source = np.full((rows, cols), -1, dtype=np.int64)
    for d_row, d_col in _DIRECTIONS:
        nearest = []
        for sign in (1, -1):
            found = np.full((rows, cols), -1, dtype=np.int64)
            for step in range(reach, 0, -1):  # the nearest known cell wins: written last
                there = _shifted(index, sign * step * d_row, sign * step * d_col, -1)
                found = np.where(there >= 0, there, found)
            nearest.append(found)
        ahead, behind = nearest
        between = ~known & (ahead >= 0) & (behind >= 0)
        if not between.any():
            continue
        ahead_height = flat_height[np.maximum(ahead, 0)]
        behind_height = flat_height[np.maximum(behind, 0)]
        lower = np.where(ahead_height <= behind_height, ahead, behind)
        lower_height = np.minimum(ahead_height, behind_height)
        better = between & (lower_height > best_height)
        best_height[better] = lower_height[better]
        best_source[better] = lower[better]
    filled = best_source >= 0
    if not filled.any():
        return False
    source = best_source[filled]
    maps.height[filled] = flat_height[source]
    maps.color[filled] = maps.color.reshape(-1, 3)[source]
    if maps.labels is not None:
        maps.labels[filled] = maps.labels.reshape(-1)[source]
    maps.filled |= filled
    return True


class HeightmapProjector:
    """Projects frames of one fixed camera (intrinsics, pose, image size) onto one grid.

    The camera ray of every pixel is expressed in base_link once; a frame then costs three
    multiply-adds per pixel, a bounds test and one scatter-max.
    """

    def __init__(self, intrinsics, camera_pose, image_shape, grid: HeightmapGrid = HeightmapGrid()):
        self.intrinsics = validate_intrinsics(intrinsics)
        self.camera_pose = np.asarray(camera_pose, dtype=np.float64).reshape(4, 4)
        if not np.all(np.isfinite(self.camera_pose)):
            raise ValueError("camera pose has non-finite entries")
        self.image_shape = (int(image_shape[0]), int(image_shape[1]))
        self.grid = grid
        height, width = self.image_shape
        fx, fy = self.intrinsics[0, 0], self.intrinsics[1, 1]
        cx, cy = self.intrinsics[0, 2], self.intrinsics[1, 2]
        cols, rows = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
        rays_camera = np.stack([(cols - cx) / fx, (rows - cy) / fy, np.ones_like(cols)], axis=0)
        rays_base = self.camera_pose[:3, :3] @ rays_camera.reshape(3, -1)
        # point(depth) = origin + depth * ray, all in base_link; heights measured from the table
        self._rays = rays_base.astype(np.float32)
        self._origin = self.camera_pose[:3, 3].astype(np.float32)
        self._table_geometry(rays_base)

    def _table_geometry(self, rays_base: np.ndarray) -> None:
        """Where each pixel's ray meets the table plane: which pixels look at the workspace (and at
        what depth the table lies along them), and the largest table footprint of one pixel there."""
        grid, origin = self.grid, self.camera_pose[:3, 3]
        height, width = self.image_shape
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = (grid.table_z - origin[2]) / rays_base[2]
        depth[~np.isfinite(depth) | (depth <= 0.0)] = np.nan
        x = origin[0] + depth * rays_base[0]
        y = origin[1] + depth * rays_base[1]
        in_workspace = (x >= grid.x_min) & (x < grid.x_max) & (y >= grid.y_min) & (y < grid.y_max)
        self._workspace_pixels = np.flatnonzero(in_workspace)
        self._table_depth = depth[self._workspace_pixels].astype(np.float32)
        # the cell where each of those pixels' rays meets the table plane: where a pixel without depth goes
        table_col = np.floor((x[self._workspace_pixels] - grid.x_min) / grid.resolution).astype(np.int64)
        table_row = np.floor((y[self._workspace_pixels] - grid.y_min) / grid.resolution).astype(np.int64)
        rows, cols = grid.shape
        self._table_cells = np.clip(table_row, 0, rows - 1) * cols + np.clip(table_col, 0, cols - 1)
        self._workspace_ray_z = self._rays[2, self._workspace_pixels]
        # a pixel's footprint: the extent along x and y of the parallelogram between neighbouring
        # pixels' table points. When it is at most a cell everywhere, every cell holds a sample.
        points = np.stack([x, y]).reshape(2, height, width)
        along_cols = np.abs(np.diff(points, axis=2))[:, :-1, :]
        along_rows = np.abs(np.diff(points, axis=1))[:, :, :-1]
        extent = (along_cols + along_rows).max(axis=0)
        looking = in_workspace.reshape(height, width)[:-1, :-1] & np.isfinite(extent)
        # footprint: m of table one pixel covers at most (along x or y) over the workspace; NaN when the
        # camera does not look at the workspace
        self.footprint = float(extent[looking].max()) if looking.any() else math.nan
        # gap_reach: the widest run of cells (along a row or a column) that can fall between two
        # samples, what fill_sampling_gaps closes; 0 when pixels are finer than cells
        ratio = self.footprint / grid.resolution
        coarse = math.isfinite(ratio) and ratio > 1.0 + 1e-6
        self.gap_reach = int(math.ceil(ratio - 1e-6)) - 1 if coarse else 0

    def matches(self, intrinsics, camera_pose, image_shape, grid: HeightmapGrid) -> bool:
        return (self.image_shape == tuple(image_shape) and self.grid == grid
                and np.allclose(self.intrinsics, np.asarray(intrinsics).reshape(3, 3))
                and np.allclose(self.camera_pose, np.asarray(camera_pose).reshape(4, 4)))

    def project(self, color: np.ndarray, depth_m: np.ndarray, labels: np.ndarray | None = None,
                fill_gaps: bool = True) -> Heightmaps:
        """color (H, W, 3) uint8, depth_m (H, W) metres with NaN/0 holes, labels (H, W) int or None.
        With `fill_gaps`, sampling gaps up to `gap_reach` cells wide are filled (fill_sampling_gaps);
        nothing is filled when the camera's pixels are finer than the cells."""
        height, width = self.image_shape
        if color.shape != (height, width, 3) or color.dtype != np.uint8:
            raise ValueError(f"colour must be ({height}, {width}, 3) uint8, got {color.shape} {color.dtype}")
        if depth_m.shape != (height, width):
            raise ValueError(f"depth must be ({height}, {width}), got {depth_m.shape}")
        if labels is not None and labels.shape != (height, width):
            raise ValueError(f"labels must be ({height}, {width}), got {labels.shape}")
        grid = self.grid
        rows, cols = grid.shape
        depth = depth_m.reshape(-1).astype(np.float32, copy=False)
        valid = np.isfinite(depth) & (depth > 0.0)
        pixel_index = np.flatnonzero(valid)
        d = depth[pixel_index]
        x = self._origin[0] + d * self._rays[0, pixel_index]
        y = self._origin[1] + d * self._rays[1, pixel_index]
        z = self._origin[2] + d * self._rays[2, pixel_index] - np.float32(grid.table_z)
        col = np.floor((x - np.float32(grid.x_min)) / np.float32(grid.resolution)).astype(np.int64)
        row = np.floor((y - np.float32(grid.y_min)) / np.float32(grid.resolution)).astype(np.int64)
        inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows) & (z <= grid.max_height)
        pixel_index, z = pixel_index[inside], np.maximum(z[inside], np.float32(0.0))
        cell_index = row[inside] * cols + col[inside]

        top = np.full(rows * cols, -np.inf, dtype=np.float32)
        np.maximum.at(top, cell_index, z)
        # one pixel that set a cell's maximum gives the cell its colour (and label); among ties the
        # last written wins. A 1-D integer scatter, then one gather per seen cell: fancy-indexing the
        # colour rows of every tied pixel (flat tops tie a lot) took 3x longer.
        winners = z >= top[cell_index]
        source_pixel = np.full(rows * cols, -1, dtype=np.int64)
        source_pixel[cell_index[winners]] = pixel_index[winners]
        seen = np.isfinite(top)
        seen_cells = np.flatnonzero(seen)
        height_map = np.where(seen, top, np.float32(0.0)).astype(np.float32)
        color_map = np.zeros((rows * cols, 3), dtype=np.uint8)
        color_map[seen_cells] = color.reshape(-1, 3)[source_pixel[seen_cells]]
        label_map = None
        if labels is not None:
            label_map = np.full(rows * cols, UNSEEN_LABEL, dtype=np.int32)
            label_map[seen_cells] = labels.reshape(-1)[source_pixel[seen_cells]]
            label_map = label_map.reshape(rows, cols)
        # pixels that look at the workspace and have no depth: their colour goes where their ray meets the
        # table plane, on cells no depth reached, as height unknown
        holes = ~valid[self._workspace_pixels]
        unknown = np.zeros(rows * cols, dtype=bool)
        if holes.any():
            hole_cells, hole_pixels = self._table_cells[holes], self._workspace_pixels[holes]
            free = ~seen[hole_cells]
            unknown[hole_cells[free]] = True
            color_map[hole_cells[free]] = color.reshape(-1, 3)[hole_pixels[free]]
        maps = Heightmaps(color=color_map.reshape(rows, cols, 3), height=height_map.reshape(rows, cols),
                          seen=seen.reshape(rows, cols), labels=label_map,
                          filled=np.zeros((rows, cols), dtype=bool), unknown=unknown.reshape(rows, cols))
        if fill_gaps and self.gap_reach > 0:
            fill_sampling_gaps(maps, self.gap_reach)
            maps.unknown &= ~maps.filled
        return maps

    def check_depth(self, depth_m: np.ndarray) -> DepthCheck:
        """Does this frame's depth fit the configured camera pose and table? Looks at the pixels whose
        ray meets the table plane inside the workspace: their points should lie on the table or on
        objects below max_height (see depth_problem for the verdict)."""
        if depth_m.shape != self.image_shape:
            raise ValueError(f"depth must be {self.image_shape}, got {depth_m.shape}")
        depth = depth_m.reshape(-1)[self._workspace_pixels].astype(np.float32, copy=False)
        valid = np.isfinite(depth) & (depth > 0.0)
        count = int(np.count_nonzero(valid))
        if count == 0:
            return DepthCheck(pixels=len(self._workspace_pixels), valid=0, below=0.0, above=0.0,
                              depth_ratio=math.nan)
        d = depth[valid]
        z = self._origin[2] + d * self._workspace_ray_z[valid] - np.float32(self.grid.table_z)
        step = max(1, count // 8000)  # the median of ~8000 evenly spread points is plenty
        ratio = float(np.median(d[::step] / self._table_depth[valid][::step]))
        step = max(1, count // TABLE_POINTS)
        pixels = self._workspace_pixels[valid][::step]
        table = fit_table(self._origin[0] + d[::step] * self._rays[0, pixels],
                          self._origin[1] + d[::step] * self._rays[1, pixels], z[::step], self.grid)
        return DepthCheck(pixels=len(self._workspace_pixels), valid=count,
                          below=float(np.count_nonzero(z < -FAR_BELOW_TABLE)) / count,
                          above=float(np.count_nonzero(z > self.grid.max_height)) / count,
                          depth_ratio=ratio, table=table)


class ProjectorCache:
    """Keeps the projector of the last camera geometry; a new one is built only when it changes."""

    def __init__(self):
        self._projector: HeightmapProjector | None = None

    def get(self, intrinsics, camera_pose, image_shape, grid: HeightmapGrid) -> HeightmapProjector:
        if self._projector is None or not self._projector.matches(intrinsics, camera_pose, image_shape, grid):
            self._projector = HeightmapProjector(intrinsics, camera_pose, image_shape, grid)
        return self._projector


_DEFAULT_CACHE = ProjectorCache()


def rgbd_to_heightmaps(color: np.ndarray, depth_m: np.ndarray, intrinsics, camera_pose,
                       grid: HeightmapGrid = HeightmapGrid(), labels: np.ndarray | None = None
                       ) -> Heightmaps:
    """One call for training and evaluation code: colour (H, W, 3) uint8 + depth (H, W) metres along
    the optical axis + 3x3 intrinsics + 4x4 T_base_cameraoptical -> Heightmaps on `grid`."""
    projector = _DEFAULT_CACHE.get(intrinsics, camera_pose, depth_m.shape[:2], grid)
    return projector.project(color, depth_m, labels)
