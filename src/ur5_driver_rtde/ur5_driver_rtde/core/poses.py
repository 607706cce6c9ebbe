"""TCP waypoints of the motion plan (base_link) <-> the poses ur-rtde commands and reports.

ur-rtde poses are [x, y, z, rx, ry, rz]: metres and an axis-angle rotation vector (rad) of the active TCP
in the controller's `base` frame. The driver sets the controller's TCP offset to zero (setTcp), so every
pose it commands is tool0's. Frames (ur5_motion.ur5_kinematics): `base` is base_link turned by pi
about z; tool0 is cell.FLANGE_TO_TCP above the gripper TCP with its z axis pointing down, so for a TCP
at p with yaw psi (gripper frame Rz(psi), z up):

    tool0 in base_link: p + (0, 0, FLANGE_TO_TCP), rotation Rz(psi) Rx(pi)
    tool0 in base:      (-p_x, -p_y, p_z + FLANGE_TO_TCP), rotation Rz(psi + pi) Rx(pi)

Rz(a) Rx(pi) is the half turn about the horizontal axis (cos(a/2), sin(a/2), 0), so its rotation vector
is pi * (cos(a/2), sin(a/2), 0).
"""

from __future__ import annotations

import math

import numpy as np

from impurity_common import cell


def ur_tool0_pose(position, yaw: float, flange_to_tcp: float = cell.FLANGE_TO_TCP) -> list:
    """ur-rtde pose [x, y, z, rx, ry, rz] (m, rad, controller `base` frame) of tool0 when the TCP is at
    `position` (x, y, z in base_link, m) with the gripper pointing down and closing along `yaw` (rad);
    flange_to_tcp (m): the gripper's TCP along tool0 z (the real gripper's, on a real cell)."""
    x, y, z = (float(v) for v in position)
    if not all(math.isfinite(v) for v in (x, y, z, float(yaw))):
        raise ValueError(f"non-finite TCP pose: position {(x, y, z)}, yaw {yaw}")
    half = (float(yaw) + math.pi) / 2.0
    return [-x, -y, z + flange_to_tcp, math.pi * math.cos(half), math.pi * math.sin(half), 0.0]


def rotation_matrix(rotation_vector) -> np.ndarray:
    """3x3 rotation of an axis-angle vector (rad), Rodrigues' formula."""
    r = np.asarray(rotation_vector, dtype=float)
    angle = float(np.linalg.norm(r))
    if angle < 1e-12:
        return np.eye(3)
    k = r / angle
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * skew + (1.0 - math.cos(angle)) * skew @ skew


def tcp_from_ur_pose(pose, flange_to_tcp: float = cell.FLANGE_TO_TCP) -> tuple:
    """((x, y, z) of the TCP in base_link (m), yaw (rad)) from a ur-rtde tool0 pose in `base`; the
    inverse of ur_tool0_pose for a gripper pointing down (yaw from tool0's x axis)."""
    if len(pose) != 6:
        raise ValueError(f"a ur-rtde pose has 6 values [x, y, z, rx, ry, rz], got {len(pose)}")
    rotation_base = rotation_matrix(pose[3:])
    flip = np.diag([-1.0, -1.0, 1.0])  # base -> base_link (Rz(pi))
    rotation = flip @ rotation_base  # tool0 in base_link = Rz(yaw) Rx(pi): x axis (cos yaw, sin yaw, 0)
    tcp_offset = rotation @ np.array([0.0, 0.0, flange_to_tcp])  # along tool0 z (down)
    position = flip @ np.asarray(pose[:3], dtype=float) + tcp_offset
    return tuple(float(v) for v in position), math.atan2(rotation[1, 0], rotation[0, 0])
