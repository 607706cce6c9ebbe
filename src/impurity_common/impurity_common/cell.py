"""Geometry of the cell, in one place: every default for workspace, heightmap, camera and gripper.

Frames follow REP-103: `base_link` is the UR5 base (x forward, y left, z up) with the table top at
z = TABLE_Z; the camera's optical frame is `camera_color_optical_frame` (z out of the lens). Their ids
live in impurity_common.names with every other ROS name (re-exported here for older imports).
Nodes expose these as parameters (bringup/config/cell.yaml); cores take them as arguments with
these defaults.
"""

import math

import numpy as np

from impurity_common.names import BASE_FRAME, CAMERA_OPTICAL_FRAME  # noqa: F401  (re-exported)

# Workspace: a 448 mm x 448 mm square in front of the UR5 base (paper section 3).
WORKSPACE_X = (0.276, 0.724)  # m, base_link
WORKSPACE_Y = (-0.224, 0.224)  # m, base_link
TABLE_Z = 0.0  # m, table top in base_link

# Heightmap: 224 x 224 pixels at 2 mm. Pixel (row, col) covers
#   x = WORKSPACE_X[0] + (col + 0.5) * RESOLUTION,  y = WORKSPACE_Y[0] + (row + 0.5) * RESOLUTION.
HEIGHTMAP_RESOLUTION = 0.002  # m / px
HEIGHTMAP_SIZE = 224  # px
CROP_SIZE = 112  # px, the attention module's target- or cluster-centric crop
# m above the table that makes a heightmap cell part of an object (attention's DBSCAN and saliency, the
# exposure check): well above depth noise (2 mm std leaves the acceptance figures unchanged), below the
# thinnest block.
OCCUPIED_HEIGHT = 0.008

# Action space (paper section 3): 16 orientations, pushes 10 cm long.
NUM_ROTATIONS = 16
PUSH_LENGTH = 0.10  # m
GRIPPER_MAX_OPENING = 0.110  # m, RG2-like stroke
# Commanded pre-grasp width, as an RG2 cell sets it: every block fits across its short side at the
# worst yaw step (60 mm x 76 mm slab at 11.25 deg -> 73 mm), while fully open fingers (110 mm) land on
# neighbours in clutter (oracle grasps at the target's centre in 40 random scenes: 37 % at 110 mm,
# 55 % at 80 mm).
# TCDD's eta: a neighbour closer than this is in the fingers' way.
GRASP_OPENING = 0.080  # m
# Gripper geometry (RG2-like), shared by the simulated gripper and the policy's clearance check.
FINGER_THICKNESS = 0.008  # m, along the closing axis
FINGER_WIDTH = 0.02  # m, across it
FINGER_LENGTH = 0.05  # m, fingertips to the palm's underside
PALM_HALF_EXTENTS = (0.07, 0.02, 0.02)  # m: along the closing axis, across it, vertical
FLANGE_TO_TCP = 0.20  # m, UR flange (tool0) to the gripper TCP along the tool axis (coupling + RG2 length)
GRIP_FORCE = 20.0  # N, total closing force (10 N per finger: 30 N squeezes light cylinders out in sim)

# Motion primitives (ur5_motion.motion turns a primitive into waypoints with these; the simulated
# arm and the real driver execute the same plan). Heights are TCP heights (fingertips) in base_link.
APPROACH_HEIGHT = 0.10  # m above the primitive's z where grasps and pushes start and end
SLOW_ZONE = 0.04  # m above z where descents slow down to CONTACT_SPEED
LIFT_HEIGHT = 0.12  # m: grasps lift this far above z; success needs >= GRASP_LIFT_SUCCESS
GRASP_LIFT_SUCCESS = 0.10  # m a grasped object must rise for the grasp to count as a success
MIN_TIP_HEIGHT = 0.005  # m: fingertips never go below table + this (z is clamped up)
MAX_TIP_HEIGHT = 0.15  # m above the table: blocks are < 0.1 m; a higher z is clamped to this
SAFE_TRAVEL_HEIGHT = 0.25  # m: the TCP travels between poses over the table only above this height
FREE_SPEED = 0.5  # m/s, moves in free space
CONTACT_SPEED = 0.25  # m/s, the last SLOW_ZONE of descents, and pushes
LIFT_SPEED = 0.4  # m/s, lifting a grasped block
LINEAR_ACCELERATION = 1.2  # m/s^2 of every Cartesian move (ur-rtde's moveL default)
GUARD_FORCE = 15.0  # N: a guarded descent stops when the gripper presses down harder than this
UR5_REACH = 0.85  # m: the UR5's reach (data sheet), measured here from the shoulder axis to tool0

# Simulated RealSense colour stream (aligned depth shares the intrinsics).
CAMERA_WIDTH = 640
CAMERA_HEIGHT = 480
CAMERA_FX = 618.62
CAMERA_FY = 618.62
CAMERA_CX = (CAMERA_WIDTH - 1) / 2.0
CAMERA_CY = (CAMERA_HEIGHT - 1) / 2.0
# Overhead camera above the workspace centre, optical axis straight down; image x (columns) runs along
# +x_base and image y (rows) along -y_base. Given as the optical frame's position (m) and orientation
# quaternion (x, y, z, w) in base_link.
CAMERA_POSITION = (0.5, 0.0, 0.75)
CAMERA_ORIENTATION = (1.0, 0.0, 0.0, 0.0)  # 180 deg about x: optical z points down (-z_base)
CAMERA_NEAR = 0.05  # m
CAMERA_FAR = 2.0  # m


def rotation_yaw(index: int) -> float:
    """Yaw (rad, about base_link +z) of rotation index 0..NUM_ROTATIONS-1."""
    return (index % NUM_ROTATIONS) * 2.0 * math.pi / NUM_ROTATIONS


def pixel_to_base(row: float, col: float, resolution: float = HEIGHTMAP_RESOLUTION,
                  x_min: float = WORKSPACE_X[0], y_min: float = WORKSPACE_Y[0]) -> tuple:
    """Heightmap pixel centre -> (x, y) in base_link (m)."""
    return x_min + (col + 0.5) * resolution, y_min + (row + 0.5) * resolution


def base_to_pixel(x: float, y: float, resolution: float = HEIGHTMAP_RESOLUTION,
                  x_min: float = WORKSPACE_X[0], y_min: float = WORKSPACE_Y[0]) -> tuple:
    """(x, y) in base_link -> heightmap (row, col), integer, unclipped."""
    return int(math.floor((y - y_min) / resolution)), int(math.floor((x - x_min) / resolution))


def crop_centered(image: np.ndarray, center_row: int, center_col: int, size: int) -> tuple:
    """size x size window of a heightmap-aligned `image` centred on (center_row, center_col), zero
    outside the image (outside the workspace nothing was seen: black, height 0). Returns (crop,
    (row0, col0))."""
    row0, col0 = int(center_row) - size // 2, int(center_col) - size // 2
    crop = np.zeros((size, size) + image.shape[2:], dtype=image.dtype)
    r_from, c_from = max(row0, 0), max(col0, 0)
    r_to, c_to = min(row0 + size, image.shape[0]), min(col0 + size, image.shape[1])
    if r_to > r_from and c_to > c_from:
        crop[r_from - row0:r_to - row0, c_from - col0:c_to - col0] = image[r_from:r_to, c_from:c_to]
    return crop, (row0, col0)


def in_workspace(x: float, y: float) -> bool:
    return WORKSPACE_X[0] <= x <= WORKSPACE_X[1] and WORKSPACE_Y[0] <= y <= WORKSPACE_Y[1]
