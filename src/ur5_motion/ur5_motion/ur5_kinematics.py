"""UR5 kinematics from its published DH parameters (pure numpy): forward kinematics, Jacobian and a
damped-least-squares IK for the gripper's TCP. The PyBullet body (ur5.py) is generated from the same
table, so the model and the simulated arm cannot disagree. Runtime nodes (cell_state_publisher's TF and
/robot_description, the real arm driver) use the same kinematics without the simulator.

Frames: DH frame 0 is the UR controller's `base`, which is base_link turned by pi about z (as in the
UR ROS driver). tool0 is DH frame 6 (z out of the flange); the TCP is FLANGE_TO_TCP further along
tool0 z, with the gripper frame's z pointing back up the wrist (Rx(pi)).
"""

from __future__ import annotations

import math

import numpy as np

from impurity_common.cell import (
    FINGER_LENGTH,
    FINGER_THICKNESS,
    FINGER_WIDTH,
    FLANGE_TO_TCP,
    GRIPPER_MAX_OPENING,
    PALM_HALF_EXTENTS,
)
from impurity_common.names import BASE_FRAME

JOINT_NAMES = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
               "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
DH_A = (0.0, -0.425, -0.39225, 0.0, 0.0, 0.0)
DH_D = (0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823)
DH_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
LINK_MASSES = (3.7, 8.393, 2.275, 1.219, 1.219, 0.1879)  # kg, UR5 data sheet
JOINT_LIMITS = ((-2 * math.pi, 2 * math.pi), (-2 * math.pi, 2 * math.pi), (-math.pi, math.pi),
                (-2 * math.pi, 2 * math.pi), (-2 * math.pi, 2 * math.pi), (-2 * math.pi, 2 * math.pi))
JOINT_EFFORTS = (150.0, 150.0, 150.0, 28.0, 28.0, 28.0)  # N m
JOINT_SPEED = 2.0  # rad/s for joint-space moves (UR5 limit: 3.15)

# The robot model's gripper body and colours (RG2-like): what the URDF's inertials, finger limits and
# visuals say; the simulator's config takes them from here.
ARM_COLOR = (0.75, 0.78, 0.80)  # RGB 0..1
GRIPPER_COLOR = (0.25, 0.25, 0.28)
PALM_MASS = 0.6  # kg
FINGER_MASS = 0.05  # kg
FINGER_FORCE = 10.0  # N per finger (30 N squeezes light cylinders out through the simulator's solver)
FINGER_SPEED = 0.35  # m/s per finger

BASE_LINK_TO_DH_BASE = np.diag([-1.0, -1.0, 1.0, 1.0])  # Rz(pi)
TOOL0_TO_TCP = np.array([[1.0, 0, 0, 0], [0, -1.0, 0, 0], [0, 0, -1.0, FLANGE_TO_TCP], [0, 0, 0, 1.0]])

# Parked out of the camera's view, to the right of the base, elbow up (found with ik(), checked in tests).
HOME_TCP = (0.22, -0.32, 0.35)
HOME_JOINTS = (-1.2534, -1.7906, 1.4572, -1.2375, -1.5708, -1.5534)


def dh_transform(a: float, d: float, alpha: float, theta: float) -> np.ndarray:
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def joint_frames(q) -> list:
    """base_link poses of DH frames 0..6 followed by the TCP (8 matrices)."""
    frames = [BASE_LINK_TO_DH_BASE.copy()]
    for i in range(6):
        frames.append(frames[-1] @ dh_transform(DH_A[i], DH_D[i], DH_ALPHA[i], q[i]))
    frames.append(frames[-1] @ TOOL0_TO_TCP)
    return frames


def tcp_pose(q) -> np.ndarray:
    return joint_frames(q)[-1]


def gripper_rotation(yaw: float) -> np.ndarray:
    """Gripper frame orientation for a top-down primitive: Rz(yaw), z up."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def pose_error(current: np.ndarray, target_position, target_rotation) -> np.ndarray:
    position_error = np.asarray(target_position) - current[:3, 3]
    r = current[:3, :3]
    rotation_error = 0.5 * sum(np.cross(r[:, i], target_rotation[:, i]) for i in range(3))
    return np.concatenate([position_error, rotation_error])


def jacobian(frames) -> np.ndarray:
    tip = frames[-1][:3, 3]
    columns = []
    for i in range(6):
        z, origin = frames[i][:3, 2], frames[i][:3, 3]
        columns.append(np.concatenate([np.cross(z, tip - origin), z]))
    return np.array(columns).T


class IKError(ValueError):
    """No joint configuration reaches the pose within the tolerance."""


def ik(position, yaw: float, seed, max_iterations: int = 100, tolerance: float = 1e-4,
       damping: float = 1e-3) -> np.ndarray:
    """Joint angles placing the TCP at position with gripper yaw, starting from seed (the arm's current
    configuration, which keeps the solution on the same branch). Raises IKError when out of reach."""
    q = np.array(seed, dtype=float)
    target_rotation = gripper_rotation(yaw)
    lower = np.array([lo for lo, _ in JOINT_LIMITS])
    upper = np.array([hi for _, hi in JOINT_LIMITS])
    error = None
    for _ in range(max_iterations):
        frames = joint_frames(q)
        error = pose_error(frames[-1], position, target_rotation)
        if np.linalg.norm(error) < tolerance:
            return q
        j = jacobian(frames)
        step = j.T @ np.linalg.solve(j @ j.T + damping * np.eye(6), error)
        q = np.clip(q + step, lower, upper)
    if error is not None and np.linalg.norm(error[:3]) < 1e-3 and np.linalg.norm(error[3:]) < 1e-2:
        return q
    raise IKError(f"no IK solution for TCP {tuple(round(float(v), 3) for v in position)} yaw {yaw:.2f} "
                  f"(residual {np.linalg.norm(error):.4f})")


def seed_towards(position) -> np.ndarray:
    """IK seed for a pose over the table: the home configuration turned towards the position (keeps
    the elbow up and the wrist on the same branch)."""
    seed = np.array(HOME_JOINTS)
    seed[0] += math.atan2(position[1], position[0]) - math.atan2(HOME_TCP[1], HOME_TCP[0])
    return seed


def nearest_equivalent_yaw(yaw: float, current_yaw: float) -> float:
    """A parallel gripper looks the same turned by pi: pick the yaw closest to the current one so the
    wrist never spins more than a quarter turn."""
    candidates = [yaw + k * math.pi for k in range(-3, 4)]
    return min(candidates, key=lambda c: abs(c - current_yaw))


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw (rad) as a rotation matrix: Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def matrix_rpy(rotation) -> tuple[float, float, float]:
    """(roll, pitch, yaw) (rad) with rpy_matrix(roll, pitch, yaw) == rotation (3 x 3, orthonormal)."""
    r = np.asarray(rotation, dtype=float)
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    if abs(r[2, 0]) < 1.0 - 1e-9:
        return math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])
    return 0.0, pitch, math.atan2(-r[0, 1], r[1, 1])  # gimbal lock: roll folded into yaw


def _numbers(values) -> str:
    return " ".join(f"{v:.17g}" for v in values)


# The UR ROS driver's tool0 is its flange frame turned by rpy (pi/2, 0, pi/2) (ur_description).
FLANGE_TO_TOOL0_RPY = (math.pi / 2, 0.0, math.pi / 2)


def urdf_text(finger_travel: float = GRIPPER_MAX_OPENING / 2.0, ros_frames: bool = False) -> str:
    """URDF of the UR5 (links from the DH table, simple cylinders as collision geometry) with the RG2-like
    gripper at the flange. Generated here so kinematics and body share one source.

    Link i's frame is DH frame i-1 turned by joint i's angle (base = DH frame 0); tool0 is DH frame 6
    and gripper_tcp the TCP of tcp_pose(). ros_frames=True (for /robot_description) adds, as the UR ROS
    driver names them, `base_link_inertia` (base_link turned by pi about z, the parent of
    shoulder_link) and `flange` (between wrist_3_link and tool0, x out of the flange); the kinematics
    are the same. The simulator loads the default (no extra links, so no extra bodies in PyBullet)."""
    color = " ".join(str(c) for c in ARM_COLOR)
    grip_color = " ".join(str(c) for c in GRIPPER_COLOR)

    def link(name, mass, geometry="", origin="0 0 0", rpy="0 0 0", rgba=color):
        shape = ""
        if geometry:
            shape = (f'<visual><origin xyz="{origin}" rpy="{rpy}"/><geometry>{geometry}</geometry>'
                     f'<material name="{name}_m"><color rgba="{rgba} 1"/></material></visual>'
                     f'<collision><origin xyz="{origin}" rpy="{rpy}"/><geometry>{geometry}</geometry>'
                     '</collision>')
        return (f'<link name="{name}"><inertial><origin xyz="{origin}"/><mass value="{mass}"/>'
                '<inertia ixx="0.005" iyy="0.005" izz="0.005" ixy="0" ixz="0" iyz="0"/></inertial>'
                f'{shape}</link>')

    def segment(a, d, radius=0.045):
        """A cylinder from the link origin to (a, 0, d): the physical link between two DH joints."""
        length = math.hypot(a, d)
        if length < 1e-6:
            return "", "0 0 0", "0 0 0"
        pitch = math.atan2(a, d)  # rotate the cylinder's z axis onto (a, 0, d)
        return (f'<cylinder radius="{radius}" length="{length:.5f}"/>', f"{a / 2:.5f} 0 {d / 2:.5f}",
                f"0 {pitch:.5f} 0")

    parts = ['<?xml version="1.0"?><robot name="ur5_rg2">',
             link(BASE_FRAME, 4.0, '<cylinder radius="0.075" length="0.06"/>', "0 0 0.03"),
             link("base", 0.01),
             f'<joint name="base_link-base_fixed_joint" type="fixed"><parent link="{BASE_FRAME}"/>'
             '<child link="base"/><origin xyz="0 0 0" rpy="0 0 3.141592653589793"/></joint>']
    parent = "base"
    if ros_frames:
        parts.append('<link name="base_link_inertia"/>')
        parts.append(f'<joint name="base_link-base_link_inertia" type="fixed"><parent link="{BASE_FRAME}"/>'
                     '<child link="base_link_inertia"/><origin xyz="0 0 0" rpy="0 0 3.141592653589793"/>'
                     '</joint>')
        parent = "base_link_inertia"
    link_names = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
                  "wrist_3_link")
    for i, name in enumerate(JOINT_NAMES):
        geometry, origin, rpy = segment(DH_A[i], DH_D[i])
        parts.append(link(link_names[i], LINK_MASSES[i], geometry, origin, rpy))
        lo, hi = JOINT_LIMITS[i]
        joint_origin = "0 0 0" if i == 0 else f"{DH_A[i - 1]} 0 {DH_D[i - 1]}"
        joint_rpy = "0 0 0" if i == 0 else f"{DH_ALPHA[i - 1]} 0 0"
        parts.append(f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
                     f'<child link="{link_names[i]}"/><origin xyz="{joint_origin}" rpy="{joint_rpy}"/>'
                     f'<axis xyz="0 0 1"/><limit lower="{lo}" upper="{hi}" effort="{JOINT_EFFORTS[i]}" '
                     f'velocity="3.15"/></joint>')
        parent = link_names[i]
    parts.append(link("tool0", 0.01))
    if ros_frames:
        flange_rpy = matrix_rpy(rpy_matrix(DH_ALPHA[5], 0.0, 0.0) @ rpy_matrix(*FLANGE_TO_TOOL0_RPY).T)
        parts.append('<link name="flange"/>')
        parts.append('<joint name="wrist_3-flange" type="fixed"><parent link="wrist_3_link"/>'
                     '<child link="flange"/>'
                     f'<origin xyz="{DH_A[5]} 0 {DH_D[5]}" rpy="{_numbers(flange_rpy)}"/></joint>')
        parts.append('<joint name="flange-tool0" type="fixed"><parent link="flange"/><child link="tool0"/>'
                     f'<origin xyz="0 0 0" rpy="{_numbers(FLANGE_TO_TOOL0_RPY)}"/></joint>')
    else:
        parts.append('<joint name="wrist_3-flange" type="fixed"><parent link="wrist_3_link"/>'
                     '<child link="tool0"/>'
                     f'<origin xyz="{DH_A[5]} 0 {DH_D[5]}" rpy="{DH_ALPHA[5]} 0 0"/></joint>')
    # Gripper frame (TCP, z up the wrist) = tool0 * Trans(0, 0, FLANGE_TO_TCP) * Rx(pi).
    palm = PALM_HALF_EXTENTS
    palm_z = FINGER_LENGTH + palm[2]
    coupling_len = FLANGE_TO_TCP - FINGER_LENGTH - 2 * palm[2]
    parts.append(link("gripper_tcp", PALM_MASS,
                      f'<box size="{2 * palm[0]} {2 * palm[1]} {2 * palm[2]}"/>', f"0 0 {palm_z}",
                      rgba=grip_color))
    parts.append(f'<joint name="tool0-gripper" type="fixed"><parent link="tool0"/><child link="gripper_tcp"/>'
                 f'<origin xyz="0 0 {FLANGE_TO_TCP}" rpy="3.141592653589793 0 0"/></joint>')
    parts.append(link("coupling", 0.2, f'<cylinder radius="0.03" length="{coupling_len:.4f}"/>',
                      "0 0 0", rgba=grip_color))
    coupling_z = palm_z + palm[2] + coupling_len / 2
    parts.append('<joint name="gripper-coupling" type="fixed"><parent link="gripper_tcp"/>'
                 f'<child link="coupling"/><origin xyz="0 0 {coupling_z:.4f}"/></joint>')
    finger_box = f'<box size="{FINGER_THICKNESS} {FINGER_WIDTH} {FINGER_LENGTH}"/>'
    for side, name in ((1, "left_finger"), (-1, "right_finger")):
        parts.append(link(name, FINGER_MASS, finger_box, rgba=grip_color))
        parts.append(f'<joint name="{name}_joint" type="prismatic"><parent link="gripper_tcp"/>'
                     f'<child link="{name}"/><origin xyz="{side * FINGER_THICKNESS / 2} 0 '
                     f'{FINGER_LENGTH / 2}"/><axis xyz="{side} 0 0"/>'
                     f'<limit lower="0" upper="{finger_travel}" effort="{FINGER_FORCE}" '
                     f'velocity="{FINGER_SPEED}"/></joint>')
    parts.append("</robot>")
    return "\n".join(parts)
