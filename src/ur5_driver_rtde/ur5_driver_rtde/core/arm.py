"""The UR5 through ur-rtde: straight moves, guarded moves and joint moves that can be stopped.

Every move is sent asynchronously (moveL / moveJ / moveJ_IK with asynchronous=True) and watched until
it ends, so the driver can stop the arm (stopL) on a cancel or when the connection drops:

    end of the move   getAsyncOperationProgress() turns negative again, to a value other than the one
                      read before the move was sent (ur-rtde toggles -1/-2 at each finished operation)
    contact           a guarded move starts the controller's contact detection in the direction of
                      motion (startContactDetection / readContactDetection, URScript's tool_contact)
                      right AFTER sending the asynchronous moveL, never before: ur-rtde's header says an
                      async move may re-upload the control script, which kills the monitoring thread
                      (rtde_control_interface.h, startContactDetection). On a contact ur-rtde's control
                      script itself stops the move and retracts to where the contact began
                      (rtde_control.script: contact_thread, then internal command 254: stop_async_move,
                      stopl(3), movel to the joints of the first contact); it owns that stop and
                      retract, the driver sends no stopL of its own and waits for the move to end.
                      With force_threshold_check on, a measured TCP force along +z above the step's
                      threshold (N) also ends the move: that stop is the driver's own (stopL, no retract)
    safety            safety mode and robot mode are read from the receive interface (getSafetyMode,
                      getRobotMode) before each move and while it runs: any safety mode but NORMAL or
                      REDUCED, or a robot mode other than RUNNING, ends the move with SafetyStop naming
                      them (e.g. "protective stop during moveL (safety mode 3 PROTECTIVE_STOP, robot
                      mode 7 RUNNING)"); `unavailable()` gives the same reason for refusing a new goal
    connection lost   isConnected() false on control or receive, or ur-rtde raising RuntimeError:
                      DriverLost, after one attempt to stopL

The controller's contact detection needs tool_contact, PolyScope 5.4 or later (e-Series): ur-rtde strips
its lines from the control script on older controllers (script_client.cpp, removeUnsupportedFunctions),
and there the contact thread reports a contact at once and nothing stops the move. force_threshold_check
is the only contact sensing there, so the arm is told the controller's PolyScope version (what the
dashboard server answers, ur-rtde's DashboardClient.polyscopeVersion): below 5.4, or when it could not be
read, a guarded move starts no contact detection and stops on the TCP force alone, and without
force_threshold_check guarded moves are refused (`contact_sensing_problem`, `unavailable`: new goals are
refused naming the version and the parameter).

`control` and `receive` are rtde_control.RTDEControlInterface and rtde_receive.RTDEReceiveInterface, or
the dry run's recording stand-ins (recording.py): this code cannot tell them apart.
"""

from __future__ import annotations

import math
import re
import time

from impurity_common import cell

from .poses import tcp_from_ur_pose, ur_tool0_pose

STOP_DECELERATION = 10.0  # m/s^2 for stopL (ur-rtde's default: a firm, controlled stop)
POLL_PERIOD = 0.004  # s between checks while a move runs (RTDE at 125-500 Hz)
MOVE_TIMEOUT_MARGIN = 5.0  # s added to the move's nominal duration before it counts as stuck
DOWN = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]  # contact direction of a descent, in the controller's base frame

# getSafetyMode()'s values (the RTDE interface's safety_mode; ur_dashboard_msgs/SafetyMode numbers them
# the same) and getRobotMode()'s (rtde_receive_interface.h, getRobotMode).
SAFETY_MODES = {1: "NORMAL", 2: "REDUCED", 3: "PROTECTIVE_STOP", 4: "RECOVERY", 5: "SAFEGUARD_STOP",
                6: "SYSTEM_EMERGENCY_STOP", 7: "ROBOT_EMERGENCY_STOP", 8: "VIOLATION", 9: "FAULT",
                10: "VALIDATE_JOINT_ID", 11: "UNDEFINED_SAFETY_MODE", 12: "AUTOMATIC_MODE_SAFEGUARD_STOP",
                13: "SYSTEM_THREE_POSITION_ENABLING_STOP"}
ROBOT_MODES = {-1: "NO_CONTROLLER", 0: "DISCONNECTED", 1: "CONFIRM_SAFETY", 2: "BOOTING", 3: "POWER_OFF",
               4: "POWER_ON", 5: "IDLE", 6: "BACKDRIVE", 7: "RUNNING", 8: "UPDATING_FIRMWARE"}
CONTACT_DETECTION_SINCE = (5, 4)  # PolyScope version with URScript's tool_contact (e-Series)
MOVING_SAFETY_MODES = (1, 2)  # NORMAL, REDUCED: the arm may move
ROBOT_RUNNING = 7
SAFETY_STOPS = {3: "protective stop", 4: "safety recovery mode", 5: "safeguard stop", 6: "emergency stop",
                7: "emergency stop", 8: "safety violation", 9: "safety fault",
                12: "safeguard stop", 13: "three-position enabling stop"}


def polyscope_version(text: str | None) -> tuple[int, int, int] | None:
    """(major, minor, bugfix) from the dashboard server's answer to PolyscopeVersion, as ur-rtde's
    DashboardClient.polyscopeVersion returns it ("5.11.1.108318", or the whole answer "URSoftware
    3.15.7.106331 (Nov 03 2021)" when it finds no such number); None when it holds no version."""
    match = re.search(r"(\d+)\.(\d+)\.(\d+)", text or "")
    return None if match is None else (int(match[1]), int(match[2]), int(match[3]))


class DriverLost(RuntimeError):
    """The controller stopped answering; str() says during what."""


class MotionFailed(RuntimeError):
    """The controller refused or did not finish a move (protective stop, limits, timeout)."""


class SafetyStop(MotionFailed):
    """The controller is not in normal operation (protective stop, emergency stop, not running...);
    str() names what and the safety and robot modes read."""


class MotionCancelled(RuntimeError):
    """The caller asked to stop; the arm was stopped."""


class UrArm:
    def __init__(self, control, receive, *, joint_speed: float = 1.05, joint_acceleration: float = 1.4,
                 force_threshold_check: bool = False, polyscope: str | None = None,
                 flange_to_tcp: float = cell.FLANGE_TO_TCP, poll_period: float = POLL_PERIOD,
                 clock=time.monotonic, sleep=time.sleep):
        self.control, self.receive = control, receive
        self.joint_speed, self.joint_acceleration = joint_speed, joint_acceleration
        self.force_threshold_check = force_threshold_check
        self.polyscope = polyscope  # the controller's PolyScope version as read (None: not read)
        version = polyscope_version(polyscope)
        # the controller stops a guarded move on contact (tool_contact)
        self.contact_detection = version is not None and version >= CONTACT_DETECTION_SINCE
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

    def modes(self) -> tuple[int, int]:
        """(safety mode, robot mode) as the receive interface reads them (SAFETY_MODES, ROBOT_MODES);
        DriverLost when it does not answer."""
        safety = int(self._call("getSafetyMode", self.receive.getSafetyMode))
        robot = int(self._call("getRobotMode", self.receive.getRobotMode))
        return safety, robot

    def mode_problem(self, when: str = "") -> str | None:
        """None while the arm may move (safety mode NORMAL or REDUCED and robot mode RUNNING), else what
        stops it, `when` and both modes, e.g. "protective stop during moveL (safety mode 3
        PROTECTIVE_STOP, robot mode 7 RUNNING)". DriverLost when the receive interface does not answer."""
        safety, robot = self.modes()
        if safety in MOVING_SAFETY_MODES and robot == ROBOT_RUNNING:
            return None
        what = SAFETY_STOPS.get(safety, "safety stop")
        if safety in MOVING_SAFETY_MODES:
            what = "robot not running"
        modes = (f"safety mode {safety} {SAFETY_MODES.get(safety, 'UNKNOWN')}, "
                 f"robot mode {robot} {ROBOT_MODES.get(robot, 'UNKNOWN')}")
        return f"{what} {when} ({modes})" if when else f"{what} ({modes})"

    def _require_normal(self, what: str) -> None:
        problem = self.mode_problem(f"before {what}")
        if problem is not None:
            raise SafetyStop(problem)

    def contact_sensing_problem(self) -> str | None:
        """Why guarded moves cannot sense a contact (a controller without contact detection and
        force_threshold_check off), naming the version and the parameter; None when they can."""
        if self.contact_detection or self.force_threshold_check:
            return None
        version = polyscope_version(self.polyscope)
        if version is None:
            controller = f"the controller's PolyScope version is unknown ({self.polyscope or 'not read'})"
        else:
            controller = f"the controller runs PolyScope {'.'.join(map(str, version))}"
        since = ".".join(map(str, CONTACT_DETECTION_SINCE))
        return (f"guarded descents refused: {controller}, and its contact detection needs PolyScope "
                f"{since}+ (e-Series); set force_threshold_check to true to stop them on the measured TCP "
                "force")

    def unavailable(self) -> str | None:
        """Why a new goal must be refused (the controller does not answer, it is not in normal
        operation, naming the safety and robot modes, or guarded descents cannot sense a contact:
        contact_sensing_problem), or None. Every primitive's plan has a guarded descent."""
        if not self.connected():
            return "driver_lost: the UR controller does not answer"
        try:
            problem = self.mode_problem()
        except DriverLost as error:
            return f"driver_lost: {error}"
        if problem is not None:
            return f"robot not in normal operation: {problem}"
        return self.contact_sensing_problem()

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
    def _wait(self, what: str, before: int, duration: float, should_stop, contact=None,
              force_contact=None) -> bool:
        """Watch a running async move; True when it ended, False when it ended on a contact.
        contact() reads the controller's contact detection (ur-rtde stops and retracts, the driver only
        waits for the end of the move); force_contact() is the driver's own check (it stops the arm)."""
        deadline = self._clock() + duration + MOVE_TIMEOUT_MARGIN
        touched = False
        while True:
            if not self.connected():
                self.stop()
                raise DriverLost(f"connection to the controller lost during {what}")
            problem = self.mode_problem(f"during {what}")
            if problem is not None:
                raise SafetyStop(problem)
            if should_stop():
                self.stop()
                raise MotionCancelled(f"{what} cancelled")
            if contact is not None and not touched:
                touched = bool(self._call("readContactDetection", contact))
            if force_contact is not None and not touched and force_contact():
                self.stop()  # never once ur-rtde retracts: a stopL would cut its retract short
                return False
            progress = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
            if progress < 0 and progress != before:
                return not touched
            if self._clock() > deadline:
                self.stop()
                raise MotionFailed(f"{what} did not finish within {duration + MOVE_TIMEOUT_MARGIN:.1f} s")
            self._sleep(self.poll_period)

    def _refused(self, what: str, target) -> MotionFailed:
        """The error for a move command the controller refused (ur-rtde returns False, e.g. in a
        protective stop: RTDEControlInterface::sendCommand)."""
        self._require_connection(what)
        problem = self.mode_problem(f"refusing {what}")
        if problem is not None:
            return SafetyStop(problem)
        return MotionFailed(f"the controller refused {what} to {[round(v, 4) for v in target]}")

    def _unwrapped_yaw(self, yaw: float) -> float:
        """A parallel gripper is the same turned by pi: the equivalent yaw nearest the last one."""
        if self.yaw is None:
            self.yaw = self.tcp()[1]
        candidates = [yaw + k * math.pi for k in range(-3, 4)]
        return min(candidates, key=lambda c: abs(c - self.yaw))

    def move_linear(self, position, yaw: float, speed: float, acceleration: float,
                    force_threshold: float | None = None, should_stop=lambda: False) -> bool:
        """Straight tool move to the TCP pose (base_link, m, rad) at speed (m/s); with force_threshold
        (N) the move is guarded: contact detection starts once moveL has been sent (on a controller that
        has it), and with force_threshold_check the TCP force is watched. Returns False when a guarded
        move ended on contact. A guarded move without contact sensing is refused (MotionFailed) before
        anything is sent."""
        self._require_connection("moveL")
        self._require_normal("moveL")
        if force_threshold is not None and (problem := self.contact_sensing_problem()) is not None:
            raise MotionFailed(problem)
        start, _ = self.tcp()
        yaw = self._unwrapped_yaw(yaw)
        pose = ur_tool0_pose(position, yaw, self.flange_to_tcp)
        duration = math.dist(start, position) / max(speed, 1e-3) + speed / max(acceleration, 1e-3)
        before = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
        if not self._call("moveL", self.control.moveL, pose, speed, acceleration, True):
            raise self._refused("moveL", pose)
        self.yaw = yaw
        if force_threshold is None:
            return self._wait("moveL", before, duration, should_stop)
        force_contact = self._force_contact(force_threshold) if self.force_threshold_check else None
        if not self.contact_detection:  # the TCP force alone (contact_sensing_problem: it is checked)
            return self._wait("moveL", before, duration, should_stop, force_contact=force_contact)
        try:
            self._call("startContactDetection", self.control.startContactDetection, DOWN)
            return self._wait("moveL", before, duration, should_stop, self.control.readContactDetection,
                              force_contact)
        finally:
            if self.connected():
                self._call("stopContactDetection", self.control.stopContactDetection)

    def _force_contact(self, force_threshold: float):
        def pressed() -> bool:
            return self._call("getActualTCPForce", self.receive.getActualTCPForce)[2] > force_threshold
        return pressed

    def move_joints_to_pose(self, position, yaw: float, should_stop=lambda: False) -> None:
        """Joint-space move to the TCP pose (base_link, m, rad) with moveJ_IK (the controller's IK, the
        solution nearest the current joints): how the arm travels across the table, above
        SAFE_TRAVEL_HEIGHT, as the simulated arm does (a straight line there may pass near a singularity)."""
        self._require_connection("moveJ_IK")
        self._require_normal("moveJ_IK")
        yaw = self._unwrapped_yaw(yaw)
        pose = ur_tool0_pose(position, yaw, self.flange_to_tcp)
        before = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
        if not self._call("moveJ_IK", self.control.moveJ_IK, pose, self.joint_speed, self.joint_acceleration,
                          True):
            raise self._refused("moveJ_IK", pose)
        self.yaw = yaw
        self._wait("moveJ_IK", before, 2.0 * math.pi / max(self.joint_speed, 1e-3), should_stop)

    def move_joints(self, q, should_stop=lambda: False) -> None:
        """Joint move (moveJ) to q (rad) at joint_speed (rad/s)."""
        self._require_connection("moveJ")
        self._require_normal("moveJ")
        current = self.joint_positions()
        duration = max(abs(a - b) for a, b in zip(q, current, strict=True)) / max(self.joint_speed, 1e-3)
        before = self._call("getAsyncOperationProgress", self.control.getAsyncOperationProgress)
        if not self._call("moveJ", self.control.moveJ, list(q), self.joint_speed, self.joint_acceleration,
                          True):
            raise self._refused("moveJ", q)
        self._wait("moveJ", before, duration, should_stop)
        self.yaw = None  # re-read from the arm before the next linear move

    def up_to_travel_height(self, speed: float, acceleration: float, should_stop=lambda: False) -> None:
        """Straight up to cell.SAFE_TRAVEL_HEIGHT when the TCP is lower (never sweep through clutter)."""
        position, yaw = self.tcp()
        if position[2] < cell.SAFE_TRAVEL_HEIGHT - 0.01:
            self.move_linear((position[0], position[1], cell.SAFE_TRAVEL_HEIGHT), yaw, speed, acceleration,
                             should_stop=should_stop)
