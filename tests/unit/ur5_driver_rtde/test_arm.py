"""Specification of the arm's use of ur-rtde against fakes of RTDEControlInterface / RTDEReceiveInterface
that record every call, queries included: a guarded move starts the controller's contact detection only
after the asynchronous moveL was sent; a contact the controller detects is stopped and retracted by
ur-rtde's control script (the driver sends no stopL and waits for the move to end), a force over the
threshold is stopped by the driver; a protective stop (or any safety mode but NORMAL / REDUCED, or a robot
mode other than RUNNING) ends the step with that reason, and new goals are refused naming the modes until
the controller is back in normal operation."""

import pytest

from impurity_common import cell, names
from impurity_common.enums import PrimitiveKind
from ur5_driver_rtde.core.arm import MotionFailed, SafetyStop, UrArm, polyscope_version
from ur5_driver_rtde.core.executor import PlanExecutor
from ur5_driver_rtde.core.recording import CommandLog, DryRunControl, DryRunReceive, DryRunRobot
from ur5_motion import motion

GRASP = ("grasp", 0.50, 0.10, 0.02, 0.3)
PROTECTIVE_STOP, ROBOT_IDLE = 3, 5
STOPPED = "protective stop (safety mode 3 PROTECTIVE_STOP, robot mode 7 RUNNING)"


class RecordingControl(DryRunControl):
    """DryRunControl whose asynchronous moves keep running (getAsyncOperationProgress 0) for
    `running_polls` reads, whose contact detection reports a contact from read number `contact_at`
    (None: never), and which records every call, in order, in `calls`. `on_poll(n)` runs at the n-th
    progress read of a running move."""

    def __init__(self, robot, running_polls=4, contact_at=None, on_poll=lambda n: None):
        super().__init__(robot.log, robot.state)
        self.calls, self.running_polls, self.contact_at, self.on_poll = [], running_polls, contact_at, on_poll
        self._left, self._polls, self._reads = 0, 0, 0

    def moveL(self, pose, speed=0.25, acceleration=1.2, asynchronous=False):  # noqa: N802
        self.calls.append("moveL")
        self._left = self.running_polls
        return super().moveL(pose, speed, acceleration, asynchronous)

    def getAsyncOperationProgress(self):  # noqa: N802
        self.calls.append("getAsyncOperationProgress")
        if self._left:
            self._left -= 1
            self._polls += 1
            self.on_poll(self._polls)
            return 0  # running
        return super().getAsyncOperationProgress()

    def startContactDetection(self, direction):  # noqa: N802
        self.calls.append("startContactDetection")
        return super().startContactDetection(direction)

    def readContactDetection(self):  # noqa: N802
        self.calls.append("readContactDetection")
        self._reads += 1
        return self.contact_at is not None and self._reads >= self.contact_at

    def stopContactDetection(self):  # noqa: N802
        self.calls.append("stopContactDetection")
        return super().stopContactDetection()

    def stopL(self, a=10.0, asynchronous=False):  # noqa: N802
        self.calls.append("stopL")
        return super().stopL(a, asynchronous)


class PressedReceive(DryRunReceive):
    """The TCP force along +z reads `force_z` (N)."""

    def __init__(self, state, force_z):
        super().__init__(state)
        self.force_z = force_z

    def getActualTCPForce(self):  # noqa: N802
        return [0.0, 0.0, self.force_z, 0.0, 0.0, 0.0]


def arm_with(robot, **options):
    options.setdefault("polyscope", robot.polyscope)
    arm = UrArm(robot.control, robot.receive, poll_period=0.0, **options)
    arm.prepare()
    return arm


def descend(arm, force_threshold=5.0):
    """A guarded descent of 5 cm below the home TCP."""
    here, yaw = arm.tcp()
    below = (here[0], here[1], here[2] - 0.05)
    return arm.move_linear(below, yaw, cell.CONTACT_SPEED, cell.LINEAR_ACCELERATION,
                           force_threshold=force_threshold)


def test_contact_detection_starts_after_the_asynchronous_move_is_sent():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot)
    assert descend(arm_with(robot)) is True  # no contact: the move ran to its end
    calls = control.calls
    assert calls.index("moveL") < calls.index("startContactDetection") < calls.index("readContactDetection")
    assert calls[-1] == "stopContactDetection"


def test_a_contact_the_controller_detects_is_stopped_by_ur_rtde_and_waited_for():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot, running_polls=4, contact_at=2)
    assert descend(arm_with(robot)) is False  # ended on contact
    assert "stopL" not in control.calls  # ur-rtde's script stops and retracts; a stopL would cut that short
    reads = [i for i, call in enumerate(control.calls) if call == "getAsyncOperationProgress"]
    assert len(reads) == 1 + 4 + 1  # before the move, while it ran, its end
    assert control.calls.count("readContactDetection") == 2  # read until the contact, not after


def test_a_force_over_the_threshold_is_stopped_by_the_driver():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot, running_polls=4)
    robot.receive = PressedReceive(robot.state, force_z=8.0)
    assert descend(arm_with(robot, force_threshold_check=True), force_threshold=5.0) is False
    assert control.calls[-2:] == ["stopL", "stopContactDetection"]


def test_once_the_controller_reports_a_contact_the_force_check_sends_no_stop():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot, running_polls=4, contact_at=1)
    robot.receive = PressedReceive(robot.state, force_z=8.0)  # pressing on the object it touched
    assert descend(arm_with(robot, force_threshold_check=True), force_threshold=5.0) is False
    assert "stopL" not in control.calls


def test_a_protective_stop_during_a_move_ends_the_step_with_its_reason():
    log = CommandLog()
    robot = DryRunRobot(log)

    def protective_stop(poll):
        if log.context.get("phase") == "descend" and poll >= 2:
            robot.state.safety_mode = PROTECTIVE_STOP

    robot.control = RecordingControl(robot, running_polls=3, on_poll=protective_stop)
    arm = arm_with(robot)
    result = PlanExecutor(arm, robot.gripper, log).execute(motion.plan_primitive(*GRASP), 1)
    assert not result.motion_completed and not result.driver_lost
    assert result.message == ("motion failed: protective stop during moveL "
                              "(safety mode 3 PROTECTIVE_STOP, robot mode 7 RUNNING)")
    assert log.records[-1]["phase"] == "descend"  # nothing was sent after the stop but a stopL
    assert log.records[-1]["command"] == "stopL"


def test_new_goals_are_refused_naming_the_modes_until_the_robot_is_back_in_normal_operation():
    robot = DryRunRobot(CommandLog())
    arm = arm_with(robot)
    robot.state.safety_mode = PROTECTIVE_STOP
    claim = motion.ArmClaim()  # the driver node's goal callback: refuse_or_claim(..., arm.unavailable)
    request = (int(PrimitiveKind.GRASP), 0.5, 0.1, 0.02, 0.3, names.BASE_FRAME)
    assert claim.refuse_or_claim(*request, arm.unavailable) == f"robot not in normal operation: {STOPPED}"
    robot.state.safety_mode = 1  # the operator unlocked the protective stop
    assert claim.refuse_or_claim(*request, arm.unavailable) is None


def test_a_robot_that_is_not_running_is_named_with_its_mode():
    robot = DryRunRobot(CommandLog())
    arm = arm_with(robot)
    robot.state.robot_mode = ROBOT_IDLE  # brakes released, no program running
    assert arm.unavailable() == ("robot not in normal operation: robot not running "
                                 "(safety mode 1 NORMAL, robot mode 5 IDLE)")


def test_no_move_is_sent_while_the_controller_is_protective_stopped():
    robot = DryRunRobot(CommandLog())
    arm = arm_with(robot)
    robot.state.safety_mode = PROTECTIVE_STOP
    with pytest.raises(SafetyStop, match="protective stop before moveL"):
        descend(arm)
    assert not any(r["command"] == "moveL" for r in robot.log.records)


class RefusingControl(DryRunControl):
    """moveL returns False, as ur-rtde's sendCommand does once the controller is protective-stopped."""

    def moveL(self, pose, speed=0.25, acceleration=1.2, asynchronous=False):  # noqa: N802
        self._state.safety_mode = PROTECTIVE_STOP
        return False


def test_a_move_refused_in_a_protective_stop_says_so():
    robot = DryRunRobot(CommandLog())
    robot.control = RefusingControl(robot.log, robot.state)
    with pytest.raises(SafetyStop, match=r"protective stop refusing moveL \(safety mode 3 PROTECTIVE_STOP"):
        descend(arm_with(robot), force_threshold=None)


# ------------------------------------------------------------------------------------ contact sensing
CB3_POLYSCOPE = "3.15.7.106331"  # a CB3 controller: no tool_contact, so no contact detection


@pytest.mark.parametrize("answer,version", [("5.11.1.108318", (5, 11, 1)), ("3.15.7.106331", (3, 15, 7)),
                                            ("URSoftware 5.4.0.80000 (Jun 01 2019)", (5, 4, 0)),
                                            ("ERROR: unknown command", None), ("", None), (None, None)])
def test_the_polyscope_version_is_read_from_the_dashboard_servers_answer(answer, version):
    assert polyscope_version(answer) == version


def test_a_controller_before_polyscope_5_4_refuses_guarded_descents_naming_force_threshold_check():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot)
    arm = arm_with(robot, polyscope=CB3_POLYSCOPE)
    assert "force_threshold_check" in arm.unavailable() and "PolyScope 3.15.7" in arm.unavailable()
    with pytest.raises(MotionFailed, match="force_threshold_check"):
        descend(arm)
    assert "moveL" not in control.calls  # refused before anything moved


@pytest.mark.parametrize("polyscope", ["5.3.1.64192", None])
def test_a_controller_without_contact_detection_or_of_unknown_version_counts_as_a_cb3(polyscope):
    arm = arm_with(DryRunRobot(CommandLog()), polyscope=polyscope)
    assert "force_threshold_check" in arm.unavailable()


def test_on_a_cb3_with_force_threshold_check_the_force_alone_stops_the_descent():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot, running_polls=4)
    robot.receive = PressedReceive(robot.state, force_z=8.0)
    arm = arm_with(robot, polyscope=CB3_POLYSCOPE, force_threshold_check=True)
    assert arm.unavailable() is None
    assert descend(arm, force_threshold=5.0) is False
    assert "startContactDetection" not in control.calls  # it would report a contact at once there
    assert control.calls[-1] == "stopL"


def test_on_a_cb3_with_force_threshold_check_a_descent_without_force_runs_to_its_end():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot, running_polls=4)
    arm = arm_with(robot, polyscope=CB3_POLYSCOPE, force_threshold_check=True)
    assert descend(arm, force_threshold=5.0) is True
    assert not {"startContactDetection", "readContactDetection", "stopL"} & set(control.calls)


def test_from_polyscope_5_4_the_controllers_contact_detection_guards_the_descent():
    robot = DryRunRobot(CommandLog())
    robot.control = control = RecordingControl(robot)
    arm = arm_with(robot, polyscope="5.4.0.80000")
    assert arm.unavailable() is None
    assert descend(arm) is True and "startContactDetection" in control.calls
