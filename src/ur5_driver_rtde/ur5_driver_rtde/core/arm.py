"""The UR5 through ur-rtde: straight moves, guarded moves and joint moves that can be stopped.

Every move is sent asynchronously (moveL / moveJ / moveJ_IK with asynchronous=True) and watched until
it ends, so the driver can stop the arm (stopL) on contact, on a cancel or when the connection drops:

    end of the move   getAsyncOperationProgress() turns negative again, to a value other than the one
                      read before the move was sent (ur-rtde toggles -1/-2 at each finished operation)
    contact           a guarded move starts the controller's contact detection in the direction of
                      motion (startContactDetection / readContactDetection, URScript's tool_contact)
                      and, when force_threshold_check is on, also stops when the measured TCP force
                      along +z exceeds the step's threshold (N)
    connection lost   isConnected() false on control or receive, or ur-rtde raising RuntimeError:
                      DriverLost, after one attempt to stopL

`control` and `receive` are rtde_control.RTDEControlInterface and rtde_receive.RTDEReceiveInterface, or
the dry run's recording stand-ins (recording.py): this code cannot tell them apart.
"""

from __future__ import annotations

import math
import time

from impurity_common import cell

from .poses import tcp_from_ur_pose, ur_tool0_pose

STOP_DECELERATION = 10.0  # m/s^2 for stopL (ur-rtde's default: a firm, controlled stop)
POLL_PERIOD = 0.004  # s between checks while a move runs (RTDE at 125-500 Hz)
MOVE_TIMEOUT_MARGIN = 5.0  # s added to the move's nominal duration before it counts as stuck
DOWN = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]  # contact direction of a descent, in the controller's base frame


class DriverLost(RuntimeError):
    """The controller stopped answering; str() says during what."""


class MotionFailed(RuntimeError):
    """The controller refused or did not finish a move (protective stop, limits, timeout)."""


class MotionCancelled(RuntimeError):
    """The caller asked to stop; the arm was stopped."""


class UrArm:
    def __init__(self, control, receive, *, joint_speed: float = 1.05, joint_acceleration: float = 1.4,
                 force_threshold_check: bool = False, flange_to_tcp: float = cell.FLANGE_TO_TCP,
                 poll_period: float = POLL_PERIOD, clock=time.monotonic, sleep=time.sleep):
        self.control, self.receive = control, receive
        self.joint_speed, self.joint_acceleration = joint_speed, joint_acceleration
        self.force_threshold_check = force_threshold_check
        self.flange_to_tcp = flange_to_tcp  # m, the mounted gripper's TCP along tool0 z
        self.poll_period, self._clock, self._sleep = poll_period, clock, sleep
        self.yaw: float | None = None  # last commanded yaw (the wrist turns at most a quarter turn)

    # ------------------------------------------------------------------------------------ state
    def _call(self, what: str, function, *args):
        """One ur-rtde call; a RuntimeError from it (socket gone) becomes DriverLost."""
        try:
            return function(*args)
        except RuntimeError as error:
            raise DriverLost(f"{what}: {error}") from error

    def connected(self) -> bool:
        try:
            return bool(self.control.isConnected() and self.receive.isConnected())
        except RuntimeError:
            return False

    def _require_connection(self, what: str) -> None:
        if not self.connected():
            raise DriverLost(f"connection to the controller lost ({what})")

    def prepare(self) -> None:
        """Zero the controller's TCP offset: every pose the driver sends is tool0's (poses.py)."""
        self._require_connection("setTcp")
        self._call("setTcp", self.control.setTcp, [0.0] * 6)

    def tcp(self) -> tuple:
        """(TCP position in base_link (m), yaw (rad)) from the measured tool0 pose."""
        self._require_connection("getActualTCPPose")
        pose = self._call("getActualTCPPose", self.receive.getActualTCPPose)
        return tcp_from_ur_pose(pose, self.flange_to_tcp)

    def joint_positions(self) -> list:
        """Measured joint angles (rad), ur5_kinematics.JOINT_NAMES order."""
        return [float(v) for v in self._call("getActualQ", self.receive.getActualQ)]

    def stop(self) -> bool:
        """Tell the arm to stop (stopL); False when that could not be sent."""
        try:
            self.control.stopL(STOP_DECELERATION)
            return True
        except RuntimeError:
            return False

    # ------------------------------------------------------------------------------------ moves
    def _wait(self, what: str, before: int, duration: float, should_stop, contact=None) -> bool:
        """Watch a running async move; True when it ended, False when contact stopped it."""
        deadline = self._clock() + duration + MOVE_TIMEOUT_MARGIN
        while True:
            if not self.connected():
                self.stop()
                raise DriverLost(f"connection to the controller lost during {what}")
            if should_stop():
                self.stop()
                raise MotionCancelled(f"{what} cancelled")
            if contact is not None and contact():
                self.stop()
                return False
            progress = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
            if progress < 0 and progress != before:
                return True
            if self._clock() > deadline:
                self.stop()
                raise MotionFailed(f"{what} did not finish within {duration + MOVE_TIMEOUT_MARGIN:.1f} s")
            self._sleep(self.poll_period)

    def _unwrapped_yaw(self, yaw: float) -> float:
        """A parallel gripper is the same turned by pi: the equivalent yaw nearest the last one."""
        if self.yaw is None:
            self.yaw = self.tcp()[1]
        candidates = [yaw + k * math.pi for k in range(-3, 4)]
        return min(candidates, key=lambda c: abs(c - self.yaw))

    def move_linear(self, position, yaw: float, speed: float, acceleration: float,
                    force_threshold: float | None = None, should_stop=lambda: False) -> bool:
        """Straight tool move to the TCP pose (base_link, m, rad) at speed (m/s); with force_threshold
        (N) the move is guarded. Returns False when a guarded move stopped on contact."""
        self._require_connection("moveL")
        start, _ = self.tcp()
        yaw = self._unwrapped_yaw(yaw)
        pose = ur_tool0_pose(position, yaw, self.flange_to_tcp)
        duration = math.dist(start, position) / max(speed, 1e-3) + speed / max(acceleration, 1e-3)
        contact = None
        if force_threshold is not None:
            self._call("startContactDetection", self.control.startContactDetection, DOWN)
            contact = self._contact(force_threshold)
        before = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
        try:
            if not self._call("moveL", self.control.moveL, pose, speed, acceleration, True):
                self._require_connection("moveL")
                raise MotionFailed(f"the controller refused moveL to {[round(v, 4) for v in pose]}")
            self.yaw = yaw
            return self._wait("moveL", before, duration, should_stop, contact)
        finally:
            if force_threshold is not None and self.connected():
                self._call("stopContactDetection", self.control.stopContactDetection)

    def _contact(self, force_threshold: float):
        def touched() -> bool:
            if self._call("readContactDetection", self.control.readContactDetection):
                return True
            if self.force_threshold_check:
                return self._call("getActualTCPForce", self.receive.getActualTCPForce)[2] > force_threshold
            return False
        return touched

    def move_joints_to_pose(self, position, yaw: float, should_stop=lambda: False) -> None:
        """Joint-space move to the TCP pose (base_link, m, rad) with moveJ_IK (the controller's IK, the
        solution nearest the current joints): how the arm travels across the table, above
        SAFE_TRAVEL_HEIGHT, as the simulated arm does (a straight line there may pass near a singularity)."""
        self._require_connection("moveJ_IK")
        yaw = self._unwrapped_yaw(yaw)
        pose = ur_tool0_pose(position, yaw, self.flange_to_tcp)
        before = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
        if not self._call("moveJ_IK", self.control.moveJ_IK, pose, self.joint_speed, self.joint_acceleration,
                          True):
            self._require_connection("moveJ_IK")
            raise MotionFailed(f"the controller refused moveJ_IK to {[round(v, 4) for v in pose]}")
        self.yaw = yaw
        self._wait("moveJ_IK", before, 2.0 * math.pi / max(self.joint_speed, 1e-3), should_stop)

    def move_joints(self, q, should_stop=lambda: False) -> None:
        """Joint move (moveJ) to q (rad) at joint_speed (rad/s)."""
        self._require_connection("moveJ")
        current = self.joint_positions()
        duration = max(abs(a - b) for a, b in zip(q, current, strict=True)) / max(self.joint_speed, 1e-3)
        before = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
        if not self._call("moveJ", self.control.moveJ, list(q), self.joint_speed, self.joint_acceleration,
                          True):
            self._require_connection("moveJ")
            raise MotionFailed(f"the controller refused moveJ to {[round(v, 4) for v in q]}")
        self._wait("moveJ", before, duration, should_stop)
        self.yaw = None  # re-read from the arm before the next linear move

    def up_to_travel_height(self, speed: float, acceleration: float, should_stop=lambda: False) -> None:
        """Straight up to cell.SAFE_TRAVEL_HEIGHT when the TCP is lower (never sweep through clutter)."""
        position, yaw = self.tcp()
        if position[2] < cell.SAFE_TRAVEL_HEIGHT - 0.01:
            self.move_linear((position[0], position[1], cell.SAFE_TRAVEL_HEIGHT), yaw, speed, acceleration,
                             should_stop=should_stop)
