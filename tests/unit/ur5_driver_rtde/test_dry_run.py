"""Specification of the real driver's command sequence, checked in its dry-run mode: for a grasp and a
push, the ur-rtde and gripper commands it would send are, step by step, the motion plan that the
simulated UR5 executed for the same primitive (a PyBullet CellWorld in arm mode); a connection lost
mid-motion aborts with driver_lost after a stop command; a cancel stops, opens and leaves."""

import json
import math

import pytest

from impurity_common import cell
from ur5_driver_rtde.core.arm import UrArm
from ur5_driver_rtde.core.executor import BIN_POSITION, PlanExecutor
from ur5_driver_rtde.core.poses import tcp_from_ur_pose
from ur5_driver_rtde.core.recording import CommandLog, DryRunControl, DryRunRobot
from ur5_motion import motion, ur5_kinematics
from ur5_motion.motion import StepKind

GRASP = ("grasp", 0.50, 0.10, 0.02, 0.3)  # on the empty table: the descent runs its full length
PUSH = ("push", 0.45, -0.10, 0.02, math.pi / 4)
TALL_BLOCK = dict(shape="cube", dims=[0.05, 0.05, 0.09], position=[0.45, -0.10, 0.046], is_target=False)
MOTIONS = ("moveL", "moveJ", "moveJ_IK")


@pytest.fixture(scope="module")
def sim_executed(tmp_path_factory):
    """The steps the simulated UR5 executed for GRASP and PUSH on the empty table, and for PUSH onto a
    block 9 cm tall (key "push_on_block", with the TCP height where the descent stopped) (needs PyBullet:
    the simulator)."""
    from ur5_driver_sim.core.world import CellWorld

    scene = tmp_path_factory.mktemp("scenes") / "tall_block.json"
    scene.write_text(json.dumps([TALL_BLOCK]))
    world = CellWorld(mode="arm")
    try:
        executed = {}
        for kind, x, y, z, yaw in (GRASP, PUSH):
            world.reset_scene("empty")
            outcome = world.execute(kind, x, y, z, yaw)
            assert kind == "grasp" or outcome.success, outcome.message
            executed[kind] = list(world.carrier.executed_steps)
        world.reset_scene("file", scene_file=str(scene))
        stroke_height = []
        world.execute(*PUSH, phase=lambda name, progress: name == "push" and stroke_height.append(
            world.carrier.tcp_position()[2]))
        executed["push_on_block"] = (list(world.carrier.executed_steps), stroke_height[0])
        return executed
    finally:
        world.close()


def dry_run(request, goal=1, robot=None, should_cancel=lambda: False, flange_to_tcp=cell.FLANGE_TO_TCP,
            **robot_options):
    log = robot.log if robot is not None else CommandLog()
    robot = robot or DryRunRobot(log, flange_to_tcp=flange_to_tcp, **robot_options)
    arm = UrArm(robot.control, robot.receive, polyscope=robot.polyscope, flange_to_tcp=flange_to_tcp,
                poll_period=0.0)
    arm.prepare()
    result = PlanExecutor(arm, robot.gripper, log).execute(motion.plan_primitive(*request), goal,
                                                           should_cancel=should_cancel)
    return result, log.records


def commands_by_step(records) -> dict:
    steps = {}
    for record in records:
        if "step" in record:
            steps.setdefault(record["step"], []).append(record)
    return steps


def assert_lands_on(command, position, yaw, speed, move="moveL"):
    """A move whose tool0 pose puts the TCP at position with the gripper turned to yaw (mod pi); moveL at
    the plan's speed (m/s) and acceleration, moveJ_IK at the arm's joint speed."""
    assert command["command"] == move and command["args"]["asynchronous"] is True
    tcp, tcp_yaw = tcp_from_ur_pose(command["args"]["pose"])
    assert tcp == pytest.approx(position, abs=1e-9)
    assert math.remainder(tcp_yaw - yaw, math.pi) == pytest.approx(0.0, abs=1e-9)
    if move == "moveL":
        assert command["args"]["speed"] == pytest.approx(speed)
        assert command["args"]["acceleration"] == pytest.approx(cell.LINEAR_ACCELERATION)


def assert_commands_carry_out(step: motion.Step, commands: list) -> None:
    """What the real driver must send for one plan step (core/executor.py's table)."""
    names = [c["command"] for c in commands]
    moves = [c for c in commands if c["command"] in MOTIONS]
    assert all(c["phase"] == step.phase and c["step_kind"] == step.kind.value for c in commands)
    if step.kind is StepKind.APPROACH:
        gripper = commands[0]
        assert gripper["interface"] == "gripper" and gripper["args"]["wait"] is False
        assert gripper["command"] == ("open" if step.width > 0 else "close")
        assert [m["command"] for m in moves] == ["moveJ_IK", "moveL"]  # across in joint space, down
        assert_lands_on(moves[0], (*step.position[:2], cell.SAFE_TRAVEL_HEIGHT), step.yaw, None, "moveJ_IK")
        assert_lands_on(moves[1], step.position, step.yaw, step.speed)
    elif step.kind is StepKind.GRIPPER:
        assert len(commands) == 1 and commands[0]["interface"] == "gripper"
        args = commands[0]["args"]
        assert commands[0]["command"] == ("open" if step.width > 0 else "close")
        assert (args["force"], args["wait"]) == (step.grip_force, step.wait)
        if step.width > 0:
            assert args["width"] == step.width
    elif step.kind is StepKind.GUARDED:
        assert names == ["moveL", "startContactDetection", "stopContactDetection"]  # detection after the move
        assert commands[1]["args"]["direction"][:3] == [0.0, 0.0, -1.0]
        assert_lands_on(moves[0], step.position, step.yaw, step.speed)
    elif step.kind in (StepKind.LINEAR, StepKind.LIFT, StepKind.STROKE):
        assert names == ["moveL"]  # dry run: the TCP is where the previous step put it, so LIFT/STROKE
        assert_lands_on(moves[0], step.position, step.yaw, step.speed)  # land on the plan's waypoint
    elif step.kind is StepKind.RETREAT:
        assert names[-1] == "moveJ"
        assert moves[-1]["args"]["q"] == pytest.approx(list(ur5_kinematics.HOME_JOINTS))
        if len(moves) == 2:
            assert moves[0]["args"]["pose"][2] == pytest.approx(cell.SAFE_TRAVEL_HEIGHT + cell.FLANGE_TO_TCP)
    else:
        pytest.fail(f"unexpected step kind {step.kind}")


@pytest.mark.simulator
@pytest.mark.parametrize("request_", [GRASP, PUSH], ids=["grasp", "push"])
def test_dry_run_commands_are_the_plan_the_simulated_arm_executed(request_, sim_executed):
    plan = motion.plan_primitive(*request_)
    simulated = sim_executed[request_[0]]
    assert simulated == list(plan.steps)  # the simulated arm ran the whole plan, retreat included
    result, records = dry_run(request_, held_width=0.0)  # nothing between the fingers, as in the sim
    assert result.motion_completed, result.message
    by_step = commands_by_step(records)
    assert [plan.steps[i] for i in sorted(by_step)] == simulated
    assert list(by_step) == sorted(by_step)  # in the plan's order, each step's commands together
    for index, commands in by_step.items():
        assert_commands_carry_out(plan.steps[index], commands)


@pytest.mark.simulator
def test_a_descent_stopped_on_an_object_is_cut_short_as_in_the_simulator(sim_executed):
    simulated, contact_height = sim_executed["push_on_block"]
    plan = motion.plan_primitive(*PUSH)
    guarded = [s for s in plan.steps if s.kind is StepKind.GUARDED]
    assert guarded[1] not in simulated and guarded[0] in simulated  # the block stopped the first part
    result, records = dry_run(PUSH, contact_height=contact_height)
    assert result.motion_completed and "descent stopped on contact" in result.message
    by_step = commands_by_step(records)
    assert [plan.steps[i] for i in sorted(by_step)] == simulated
    first_descent = [c["command"] for c in by_step[plan.steps.index(guarded[0])]]
    assert first_descent == ["moveL", "startContactDetection", "stopContactDetection"]  # ur-rtde stops it
    stroke = plan.steps.index(next(s for s in plan.steps if s.kind is StepKind.STROKE))
    end = plan.steps[stroke].position
    assert_lands_on(by_step[stroke][0], (end[0], end[1], contact_height), PUSH[4], cell.CONTACT_SPEED)


def test_the_mounted_gripper_length_moves_tool0_not_the_tcp():
    plan = motion.plan_primitive(*PUSH)
    _, records = dry_run(PUSH, flange_to_tcp=0.16)  # e.g. a 2F-85 on a short coupling
    stroke = plan.steps.index(next(s for s in plan.steps if s.kind is StepKind.STROKE))
    command = commands_by_step(records)[stroke][0]
    assert command["args"]["pose"][2] == pytest.approx(plan.steps[stroke].position[2] + 0.16)


def test_a_held_object_is_released_in_the_bin_between_lift_and_retreat():
    result, records = dry_run(GRASP, held_width=0.03)
    assert result.success and result.holding and result.gripper_opening == pytest.approx(0.03)
    phases = [r["phase"] for r in records if "phase" in r]
    lift, retreat = phases.index("lift"), phases.index("retreat")
    assert set(phases[lift + 1:retreat]) == {"bin"}
    release = [r for r in records if r.get("phase") == "bin" and r["interface"] == "gripper"]
    assert [r["command"] for r in release] == ["open"]


def test_push_result_reports_a_completed_motion_without_a_grasp():
    result, _ = dry_run(PUSH)
    assert result.success and result.motion_completed and not result.holding
    assert result.gripper_opening == -1.0


def test_connection_dropped_at_a_command_aborts_with_driver_lost_and_a_stop():
    result, records = dry_run(GRASP, drop_after=3)  # the 4th motion command never reaches the arm
    assert result.message.startswith("driver_lost:") and result.driver_lost
    assert not result.success and not result.motion_completed
    moves = [i for i, r in enumerate(records) if r["command"] in MOTIONS]
    assert len(moves) == 4
    assert "stopL" in [r["command"] for r in records[moves[-1]:]]


class _ControlLosingConnectionMidMotion(DryRunControl):
    """A move that keeps running (progress >= 0) until the connection drops during its third poll."""

    def __init__(self, robot, lose_at_move: int):
        super().__init__(robot.log, robot.state)
        self._moves, self._lose_at, self._polls = 0, lose_at_move, 0

    def moveL(self, pose, speed=0.25, acceleration=1.2, asynchronous=False):  # noqa: N802
        self._moves += 1
        return super().moveL(pose, speed, acceleration, asynchronous)

    def getAsyncOperationProgress(self):  # noqa: N802
        if self._moves == self._lose_at:
            self._polls += 1
            if self._polls >= 3:
                self._state.connected = False
            return 0  # still running
        return super().getAsyncOperationProgress()


def test_connection_lost_while_the_arm_moves_stops_the_arm_and_aborts():
    robot = DryRunRobot(CommandLog())
    robot.control = _ControlLosingConnectionMidMotion(robot, lose_at_move=3)  # the first guarded descent
    result, records = dry_run(GRASP, robot=robot)
    assert result.message.startswith("driver_lost:") and "during moveL" in result.message
    last_move = max(i for i, r in enumerate(records) if r["command"] == "moveL")
    assert records[last_move]["phase"] == "descend"
    assert "stopL" in [r["command"] for r in records[last_move + 1:]]
    assert not any(r["command"] in MOTIONS for r in records[last_move + 1:])


class _ControlRaisingOnMove(DryRunControl):
    def moveL(self, pose, speed=0.25, acceleration=1.2, asynchronous=False):  # noqa: N802
        raise RuntimeError("RTDE control interface: socket closed")


def test_an_rtde_error_is_a_lost_driver_and_the_arm_is_told_to_stop():
    robot = DryRunRobot(CommandLog())
    robot.control = _ControlRaisingOnMove(robot.log, robot.state)
    result, records = dry_run(PUSH, robot=robot)
    assert result.message.startswith("driver_lost: moveL: RTDE control interface: socket closed")
    assert records[-1]["command"] == "stopL"


def test_a_cancel_during_the_descent_stops_opens_and_leaves_home():
    log = CommandLog()
    robot = DryRunRobot(log)
    result, records = dry_run(GRASP, robot=robot, should_cancel=lambda: log.context.get("phase") == "descend")
    assert result.message == "cancelled" and not result.motion_completed
    assert not any(r.get("phase") == "descend" and r["command"] in MOTIONS for r in records)
    after = [r["command"] for r in records if r.get("phase") == "abort"]
    assert after[0] == "stopL" and after[1] == "open" and after[-1] == "moveJ"


def test_a_bin_out_of_reach_is_refused_at_start_naming_the_parameter():
    from impurity_common.parameters import ParameterError, build, parameter_specs
    from ur5_driver_rtde.ur5_driver_node import Ur5DriverParameters

    defaults = {spec.name: spec.default for spec in parameter_specs(Ur5DriverParameters)}
    assert build("ur5_driver", Ur5DriverParameters, defaults).bin_position == BIN_POSITION
    with pytest.raises(ParameterError, match=r"bin_position:=\[1.5, 1.5, 0.2\] is out of the UR5's reach"):
        build("ur5_driver", Ur5DriverParameters, {**defaults, "bin_position": [1.5, 1.5, 0.2]})
