"""The real UR5 driver (ur5_driver_rtde's ur5_driver) as a process in dry-run mode, through its ROS
interfaces: /joint_states with UR joint names, a grasp goal that succeeds with the commands it would
send in the JSONL log, an out-of-workspace goal rejected with its reason (nothing sent), and a connection
dropped mid-plan that aborts the goal with driver_lost after a stop command. Its lifecycle, driven as
the launchers drive it: goals are refused until it is configured and activated, and a controller that
refuses the connection (ur-rtde against an address where none listens) fails configure with the reason."""

import json
import math

import pytest
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Point
from sensor_msgs.msg import JointState

from impurity_bringup.lifecycle import LifecycleFailed
from impurity_common import names
from impurity_interfaces.action import ExecutePrimitive
from impurity_interfaces.msg import Primitive
from ros_harness import ActionHelper, TopicRecorder, activate, ros_args, spin_until
from ur5_motion import motion, ur5_kinematics

MOTIONS = ("moveL", "moveJ", "moveJ_IK")


def goal(kind, x, y, z, yaw):
    msg = Primitive(kind=kind, position=Point(x=x, y=y, z=z), yaw=yaw)
    msg.header.frame_id = names.BASE_FRAME
    return ExecutePrimitive.Goal(primitive=msg)


def read_log(path):
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def test_dry_run_driver_serves_grasps_and_refuses_bad_goals(ros_node, launch, tmp_path):
    log_path = tmp_path / "commands.jsonl"
    driver = launch("ur5_driver_rtde", "ur5_driver", ros_args({
        "dry_run": True, "dry_run_log": str(log_path), "dry_run_held_width": 0.03}))
    procs = [driver]
    activate(ros_node, "/ur5_driver", processes=procs)
    joints = TopicRecorder(ros_node, JointState, names.JOINT_STATES_TOPIC, 20)
    first = joints.wait_for(1, 30.0, processes=procs)[0]
    assert tuple(first.name) == ur5_kinematics.JOINT_NAMES
    assert list(first.position) == list(ur5_kinematics.HOME_JOINTS)

    action = ActionHelper(ros_node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION, processes=procs)
    sent_before = len(read_log(log_path))
    outside = action.send_goal(goal(Primitive.GRASP, 0.9, 0.0, 0.02, 0.0))
    assert not outside.accepted
    reason = motion.validate_primitive("grasp", 0.9, 0.0, 0.02, 0.0)
    spin_until(ros_node, lambda: f"goal rejected: {reason}" in driver.output(), 10.0,
               "the rejection's reason in the driver's log", procs)
    assert len(read_log(log_path)) == sent_before  # the arm was told nothing

    wrapped = action.run(goal(Primitive.GRASP, 0.5, 0.1, 0.02, 0.3), timeout=60.0)[1]
    assert wrapped.status == GoalStatus.STATUS_SUCCEEDED
    result = wrapped.result
    assert result.success and result.motion_completed and result.holding, result.message
    assert math.isclose(result.gripper_opening, 0.03, abs_tol=1e-6)
    assert (result.target_grasped, result.grasped_object_id) == (False, -1)  # simulator-only fields
    records = [r for r in read_log(log_path) if r.get("goal") == 1]
    plan = motion.plan_primitive("grasp", 0.5, 0.1, 0.02, 0.3)
    assert sorted({r["step"] for r in records if r["phase"] != "bin"}) == list(range(len(plan.steps)))
    assert [r["command"] for r in records if r["step_kind"] == "guarded"] == [
        "moveL", "startContactDetection", "stopContactDetection"] * 2
    assert records[-1]["command"] == "moveJ"  # home
    action.destroy()
    joints.destroy()


def test_connection_dropped_mid_plan_aborts_with_driver_lost(ros_node, launch, tmp_path):
    log_path = tmp_path / "commands.jsonl"
    driver = launch("ur5_driver_rtde", "ur5_driver", ros_args({
        "dry_run": True, "dry_run_log": str(log_path), "dry_run_drop_after": 3}))
    procs = [driver]
    activate(ros_node, "/ur5_driver", processes=procs)
    action = ActionHelper(ros_node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION, processes=procs)
    wrapped = action.run(goal(Primitive.PUSH, 0.45, -0.1, 0.02, math.pi / 4), timeout=60.0)[1]
    assert wrapped.status == GoalStatus.STATUS_ABORTED
    assert wrapped.result.message.startswith("driver_lost:") and not wrapped.result.motion_completed
    records = read_log(log_path)
    last_motion = max(i for i, r in enumerate(records) if r["command"] in MOTIONS)
    assert "stopL" in [r["command"] for r in records[last_motion + 1:]]
    # While the controller does not answer, goals are refused instead of queued.
    assert not action.send_goal(goal(Primitive.PUSH, 0.45, -0.1, 0.02, 0.0)).accepted
    action.destroy()


def test_goals_are_refused_until_the_driver_is_configured_and_activated(ros_node, launch):
    driver = launch("ur5_driver_rtde", "ur5_driver", ros_args({"dry_run": True}))
    procs = [driver]
    action = ActionHelper(ros_node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION, processes=procs)
    assert not action.send_goal(goal(Primitive.PUSH, 0.45, -0.1, 0.02, 0.0)).accepted
    spin_until(ros_node, lambda: "goal rejected: the driver is unconfigured, not active" in driver.output(),
               10.0, "the refusal's reason in the driver's log", procs)
    activate(ros_node, "/ur5_driver", processes=procs)
    wrapped = action.run(goal(Primitive.PUSH, 0.45, -0.1, 0.02, 0.0), timeout=60.0)[1]
    assert wrapped.status == GoalStatus.STATUS_SUCCEEDED, wrapped.result.message
    action.destroy()


def test_a_controller_that_refuses_the_connection_fails_configure_with_the_reason(ros_node, launch):
    # ur-rtde itself, against the local host where no UR controller listens: the connection is refused
    driver = launch("ur5_driver_rtde", "ur5_driver", ros_args({"dry_run": False, "robot_ip": "127.0.0.1",
                                                               "gripper": "dry_run"}))
    with pytest.raises(LifecycleFailed) as failed:
        activate(ros_node, "/ur5_driver", processes=[driver])
    assert str(failed.value).startswith("/ur5_driver did not become active: unconfigured: configure failed: "
                                        "cannot connect to the UR controller at 127.0.0.1:")
    assert "check robot_ip" in str(failed.value) and driver.alive  # it stays up, to be configured again

