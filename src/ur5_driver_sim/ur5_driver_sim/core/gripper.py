"""The RG2-like parallel gripper and the two ways of carrying it: a floating body (fast training mode)
and the UR5 arm (driver mode, see ur5.py). Both expose the same `Carrier` interface so the primitive
code in primitives.py is one code path for both modes.

Gripper frame: origin at the TCP (between the fingertips' lower ends), z up towards the wrist, fingers
closing along x. A primitive's yaw is the closing axis, so the gripper frame is Rz(yaw) with z up.
"""

from __future__ import annotations

import math

from ur5_motion import ur5_kinematics as ur5_model

from . import config


class MotionCancelled(Exception):
    """Raised inside a motion when the caller's cancel check says stop."""


def finger_link_specs(pb):
    """Collision/visual shapes and joint layout of the two fingers, relative to the palm/TCP frame.
    Returned as a list of dicts (one per finger) used by both the floating body and the arm."""
    half = [config.FINGER_THICKNESS / 2, config.FINGER_WIDTH / 2, config.FINGER_LENGTH / 2]
    specs = []
    for side in (+1.0, -1.0):
        collision = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half)
        visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half,
                                      rgbaColor=list(config.GRIPPER_COLOR) + [1])
        specs.append(dict(mass=config.FINGER_MASS, collision=collision, visual=visual,
                          position=(side * config.FINGER_THICKNESS / 2, 0.0, config.FINGER_LENGTH / 2),
                          axis=(side, 0.0, 0.0)))
    return specs


def palm_shapes(pb):
    half = list(config.PALM_HALF_EXTENTS)
    offset = (0.0, 0.0, config.FINGER_LENGTH + half[2])
    collision = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, collisionFramePosition=offset)
    visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, visualFramePosition=offset,
                                  rgbaColor=list(config.GRIPPER_COLOR) + [1])
    return collision, visual


def yaw_quat(yaw: float) -> tuple:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class Carrier:
    """What primitives need from whatever holds the gripper. Positions are TCP positions in base_link."""

    body: int
    finger_joints: tuple
    yaw: float = 0.0  # of the last commanded pose

    def __init__(self, pb, step_fn):
        self.pb = pb
        self._step = step_fn  # world.step(): one physics step plus hooks and the cancel check
        self.executed_steps = []  # ur5_motion.motion Steps of the last plan, in the order they ran
        self.pending_retreat = None  # the last plan's RETREAT step, recorded when go_home runs it

    # --- fingers -------------------------------------------------------------------------------------
    def command_opening(self, width: float) -> None:
        travel = min(max(width / 2.0, 0.0), config.FINGER_MAX_TRAVEL)
        for joint in self.finger_joints:
            self.pb.setJointMotorControl2(self.body, joint, self.pb.POSITION_CONTROL, targetPosition=travel,
                                          force=config.FINGER_FORCE, maxVelocity=config.FINGER_SPEED)

    def opening(self) -> float:
        return sum(self.pb.getJointState(self.body, j)[0] for j in self.finger_joints)

    def move_fingers(self, width: float, steps: int = config.CLOSE_SETTLE_STEPS) -> float:
        self.command_opening(width)
        for _ in range(steps):
            self._step()
        return self.opening()

    def pressing_down(self, threshold: float = config.GUARD_FORCE) -> bool:
        """True when something pushes the gripper up harder than threshold (N; a guarded descent)."""
        total = 0.0
        for contact in self.pb.getContactPoints(bodyA=self.body):
            if contact[2] == self.body:
                continue
            normal_z = contact[7][2]  # normal on B pointing towards A: up when the gripper sits on B
            total += contact[9] * max(normal_z, 0.0)
        return total > threshold

    def touches(self, body: int) -> bool:
        return bool(self.pb.getContactPoints(bodyA=self.body, bodyB=body))

    # --- motion (implemented by the carriers) ---------------------------------------------------------
    def tcp_position(self):
        raise NotImplementedError

    def go_to_start(self, position, yaw: float, opening: float) -> None:
        """Bring the gripper to a primitive's start pose (above the action) with the given opening."""
        raise NotImplementedError

    def move_linear(self, target, yaw: float, speed: float, guarded: bool = False,
                    guard_force: float = config.GUARD_FORCE) -> bool:
        """Straight TCP line to target (m) at speed (m/s); returns False when a guarded move stopped on
        contact (pushed up harder than guard_force, N)."""
        raise NotImplementedError

    def go_home(self) -> None:
        """Leave the camera's view; completes the last plan's pending RETREAT step (executed_steps)."""
        self._go_home()
        if self.pending_retreat is not None:
            self.executed_steps.append(self.pending_retreat)
            self.pending_retreat = None

    def _go_home(self) -> None:
        raise NotImplementedError

    def joint_positions(self) -> dict:
        return {}


class FloatingCarrier(Carrier):
    """A gripper with no arm, dragged by a fixed constraint: the fast mode for training."""

    PARK_POSITION = (0.5, 0.0, 2.0)  # behind the overhead camera, out of its view

    def __init__(self, pb, step_fn):
        super().__init__(pb, step_fn)
        palm_collision, palm_visual = palm_shapes(pb)
        fingers = finger_link_specs(pb)
        self.body = pb.createMultiBody(
            baseMass=config.PALM_MASS, baseCollisionShapeIndex=palm_collision,
            baseVisualShapeIndex=palm_visual,
            basePosition=self.PARK_POSITION, baseOrientation=(0, 0, 0, 1),
            linkMasses=[f["mass"] for f in fingers],
            linkCollisionShapeIndices=[f["collision"] for f in fingers],
            linkVisualShapeIndices=[f["visual"] for f in fingers],
            linkPositions=[f["position"] for f in fingers], linkOrientations=[(0, 0, 0, 1)] * 2,
            linkInertialFramePositions=[(0, 0, 0)] * 2, linkInertialFrameOrientations=[(0, 0, 0, 1)] * 2,
            linkParentIndices=[0, 0], linkJointTypes=[pb.JOINT_PRISMATIC] * 2,
            linkJointAxis=[f["axis"] for f in fingers])
        self.finger_joints = (0, 1)
        for link in (-1, 0, 1):
            pb.changeDynamics(self.body, link, lateralFriction=config.FINGER_LATERAL_FRICTION)
        self.constraint = pb.createConstraint(self.body, -1, -1, -1, pb.JOINT_FIXED, (0, 0, 0), (0, 0, 0),
                                              self.PARK_POSITION)
        self._target = list(self.PARK_POSITION)
        self._drive(self._target, 0.0)

    def _drive(self, position, yaw):
        self.pb.changeConstraint(self.constraint, jointChildPivot=list(position),
                                 jointChildFrameOrientation=yaw_quat(yaw), maxForce=config.CARRIER_MAX_FORCE)

    def _teleport(self, position, yaw, opening):
        self.pb.resetBasePositionAndOrientation(self.body, position, yaw_quat(yaw))
        self.pb.resetBaseVelocity(self.body, (0, 0, 0), (0, 0, 0))
        travel = min(max(opening / 2, 0.0), config.FINGER_MAX_TRAVEL)
        for joint in self.finger_joints:
            self.pb.resetJointState(self.body, joint, travel)
        self.command_opening(opening)
        self._target, self.yaw = list(position), yaw
        self._drive(position, yaw)

    def tcp_position(self):
        return self.pb.getBasePositionAndOrientation(self.body)[0]

    def go_to_start(self, position, yaw, opening):
        self._teleport(position, yaw, opening)

    def move_linear(self, target, yaw, speed, guarded=False, guard_force=config.GUARD_FORCE):
        start = list(self._target)
        self.yaw = yaw
        distance = math.dist(start, target)
        steps = max(1, int(math.ceil(distance / (speed * config.TIME_STEP))))
        for i in range(1, steps + 1):
            s = i / steps
            self._target = [a + (b - a) * s for a, b in zip(start, target, strict=True)]
            self._drive(self._target, yaw)
            self._step()
            if guarded and self.pressing_down(guard_force):
                self._target = list(self.tcp_position())
                self._drive(self._target, yaw)
                return False
        for _ in range(4):  # let the constraint catch up with the last set-point
            self._step()
        return True

    def _go_home(self):
        self._teleport(self.PARK_POSITION, 0.0, 0.0)

    def joint_positions(self) -> dict:
        """No arm: report the UR5 parked at home, so /joint_states stays well-formed."""
        return dict(zip(ur5_model.JOINT_NAMES, ur5_model.HOME_JOINTS, strict=True))
