"""The UR5 carrying the gripper in PyBullet: driver mode. Motions are IK (ur5_model) + joint position
control, stepped through real physics, so joint states are those of a moving arm.
"""

from __future__ import annotations

import math
import os
import tempfile

import numpy as np

from impurity_common import cell
from ur5_motion import ur5_kinematics as ur5_model

from . import config
from .gripper import Carrier

SAFE_HEIGHT = cell.SAFE_TRAVEL_HEIGHT  # m: joint-space moves only above this TCP height
TRACKING_TOLERANCE = 0.0005  # rad: a move ends when every joint is this close (0.3 mm at the TCP)
MAX_SETTLE_STEPS = 120  # after a trajectory, steps allowed for the joints to catch up
POSITION_GAIN = 0.4
VELOCITY_GAIN = 1.0


class ArmCarrier(Carrier):
    def __init__(self, pb, step_fn):
        super().__init__(pb, step_fn)
        fd, path = tempfile.mkstemp(suffix=".urdf", prefix="ur5_rg2_")
        try:
            with os.fdopen(fd, "w") as handle:
                handle.write(ur5_model.urdf_text())
            self.body = pb.loadURDF(path, basePosition=(0, 0, 0), useFixedBase=True,
                                    flags=pb.URDF_USE_INERTIA_FROM_FILE)
        finally:
            os.unlink(path)
        names = {pb.getJointInfo(self.body, j)[1].decode(): j for j in range(pb.getNumJoints(self.body))}
        links = {pb.getJointInfo(self.body, j)[12].decode(): j for j in range(pb.getNumJoints(self.body))}
        self.arm_joints = tuple(names[n] for n in ur5_model.JOINT_NAMES)
        self.finger_joints = (names["left_finger_joint"], names["right_finger_joint"])
        self.tcp_link = links["gripper_tcp"]
        for link in (self.tcp_link, *self.finger_joints):
            pb.changeDynamics(self.body, link, lateralFriction=config.FINGER_LATERAL_FRICTION)
        self.q = np.array(ur5_model.HOME_JOINTS)  # last commanded configuration (IK seed)
        for joint, value in zip(self.arm_joints, self.q, strict=True):
            pb.resetJointState(self.body, joint, value)
        self._command_joints(self.q)
        self.yaw = self._tcp_yaw(self.q)
        self.command_opening(0.0)

    # ------------------------------------------------------------------------------------ low level
    @staticmethod
    def _tcp_yaw(q) -> float:
        r = ur5_model.tcp_pose(q)[:3, :3]
        return math.atan2(r[1, 0], r[0, 0])

    def _command_joints(self, q, velocities=None) -> None:
        self.pb.setJointMotorControlArray(
            self.body, self.arm_joints, self.pb.POSITION_CONTROL, targetPositions=list(q),
            targetVelocities=list(velocities) if velocities is not None else [0.0] * 6,
            forces=list(ur5_model.JOINT_EFFORTS), positionGains=[POSITION_GAIN] * 6,
            velocityGains=[VELOCITY_GAIN] * 6)

    def measured_joints(self) -> np.ndarray:
        return np.array([s[0] for s in self.pb.getJointStates(self.body, self.arm_joints)])

    def joint_positions(self) -> dict:
        return dict(zip(ur5_model.JOINT_NAMES, self.measured_joints().tolist(), strict=True))

    def tcp_position(self):
        return self.pb.getLinkState(self.body, self.tcp_link, computeForwardKinematics=True)[4]

    def _settle_joints(self) -> None:
        self._command_joints(self.q)
        for _ in range(MAX_SETTLE_STEPS):
            if np.max(np.abs(self.measured_joints() - self.q)) < TRACKING_TOLERANCE:
                return
            self._step()

    # ------------------------------------------------------------------------------------ motions
    def move_joints(self, q_target) -> None:
        """Joint-space move at JOINT_SPEED (linear interpolation of set-points)."""
        q_target = np.asarray(q_target, dtype=float)
        start = self.q.copy()
        span = float(np.max(np.abs(q_target - start)))
        steps = max(1, int(math.ceil(span / (ur5_model.JOINT_SPEED * config.TIME_STEP))))
        velocity = (q_target - start) / (steps * config.TIME_STEP)
        for i in range(1, steps + 1):
            self.q = start + (q_target - start) * (i / steps)
            self._command_joints(self.q, velocity)
            self._step()
        self._settle_joints()

    def move_linear(self, target, yaw, speed, guarded=False, guard_force=config.GUARD_FORCE):
        yaw = ur5_model.nearest_equivalent_yaw(yaw, self.yaw)
        start = np.array(ur5_model.tcp_pose(self.q)[:3, 3])
        target = np.asarray(target, dtype=float)
        distance = float(np.linalg.norm(target - start))
        steps = max(1, int(math.ceil(distance / (speed * config.TIME_STEP))))
        start_yaw, self.yaw = self.yaw, yaw
        for i in range(1, steps + 1):
            s = i / steps
            previous = self.q
            self.q = ur5_model.ik(start + (target - start) * s, start_yaw + (yaw - start_yaw) * s, previous)
            self._command_joints(self.q, (self.q - previous) / config.TIME_STEP)
            self._step()
            if guarded and self.pressing_down(guard_force):
                self.q = self.measured_joints()
                self._command_joints(self.q)
                return False
        self._settle_joints()
        return True

    def go_to_start(self, position, yaw, opening):
        self.command_opening(opening)
        yaw = ur5_model.nearest_equivalent_yaw(yaw, self.yaw)
        high = (position[0], position[1], max(SAFE_HEIGHT, position[2]))
        current = ur5_model.tcp_pose(self.q)[:3, 3]
        if current[2] < SAFE_HEIGHT - 0.01:  # never sweep in joint space through the clutter
            self.move_linear((current[0], current[1], SAFE_HEIGHT), self.yaw, config.FREE_SPEED)
        self.move_joints(ur5_model.ik(high, yaw, ur5_model.seed_towards(high)))
        self.yaw = yaw
        self.move_linear(position, yaw, config.FREE_SPEED)

    def _go_home(self):
        current = ur5_model.tcp_pose(self.q)[:3, 3]
        if current[2] < SAFE_HEIGHT - 0.01:
            self.move_linear((current[0], current[1], SAFE_HEIGHT), self.yaw, config.FREE_SPEED)
        self.move_joints(ur5_model.HOME_JOINTS)
        self.yaw = self._tcp_yaw(self.q)
