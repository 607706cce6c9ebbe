"""Specification of the motion plan (ur5_motion.motion): the steps of a grasp and a push, their
heights, speeds and limits, how a guarded stop ends a descent, and the reasons a primitive is refused
before anything moves."""

import math

import pytest

from impurity_common import cell
from ur5_motion import motion, ur5_kinematics
from ur5_motion.motion import StepKind


def kinds(plan):
    return [(s.kind, s.phase) for s in plan.steps]


def test_grasp_plan_is_approach_open_guarded_descent_close_lift_retreat():
    plan = motion.plan_primitive("grasp", 0.5, 0.05, 0.03, 0.4)
    assert kinds(plan) == [(StepKind.APPROACH, "approach"), (StepKind.GRIPPER, "open"),
                           (StepKind.GUARDED, "descend"), (StepKind.GUARDED, "descend"),
                           (StepKind.GRIPPER, "close"), (StepKind.LIFT, "lift"),
                           (StepKind.RETREAT, "retreat")]
    approach, opening, fast, slow, close, lift, _ = plan.steps
    assert approach.position == pytest.approx((0.5, 0.05, 0.03 + cell.APPROACH_HEIGHT))
    assert approach.width == opening.width == cell.GRASP_OPENING
    assert fast.position == pytest.approx((0.5, 0.05, 0.03 + cell.SLOW_ZONE))
    assert (fast.speed, slow.speed) == (cell.FREE_SPEED, cell.CONTACT_SPEED)
    assert slow.position == pytest.approx((0.5, 0.05, 0.03))
    assert fast.force_threshold == slow.force_threshold == cell.GUARD_FORCE
    assert close.width == 0.0 and close.wait and close.grip_force == cell.GRIP_FORCE
    assert lift.position[2] - slow.position[2] >= 0.10  # a lift of at least 10 cm (GRASP_LIFT_SUCCESS)
    assert lift.speed == cell.LIFT_SPEED
    assert all(s.yaw == 0.4 for s in plan.motion_steps)


def test_push_plan_strokes_push_length_along_yaw_then_lifts():
    yaw = math.pi / 4
    plan = motion.plan_primitive("push", 0.45, -0.05, 0.02, yaw)
    assert kinds(plan) == [(StepKind.APPROACH, "approach"), (StepKind.GRIPPER, "close"),
                           (StepKind.GUARDED, "descend"), (StepKind.GUARDED, "descend"),
                           (StepKind.STROKE, "push"), (StepKind.LINEAR, "lift"),
                           (StepKind.RETREAT, "retreat")]
    approach, close, _, slow, stroke, lift, _ = plan.steps
    assert approach.width == close.width == 0.0  # fingers closed before the descent
    start, end = slow.position, stroke.position
    assert math.dist(start[:2], end[:2]) == pytest.approx(cell.PUSH_LENGTH)
    assert math.atan2(end[1] - start[1], end[0] - start[0]) == pytest.approx(yaw)
    assert stroke.speed == cell.CONTACT_SPEED
    assert lift.position == pytest.approx((end[0], end[1], 0.02 + cell.APPROACH_HEIGHT))


def test_push_end_is_clamped_to_the_workspace():
    plan = motion.plan_primitive("push", cell.WORKSPACE_X[1] - 0.02, 0.0, 0.02, 0.0)
    stroke = next(s for s in plan.steps if s.kind is StepKind.STROKE)
    assert stroke.position[0] == pytest.approx(cell.WORKSPACE_X[1])


def test_z_is_clamped_between_min_and_max_tip_height():
    low = motion.plan_primitive("grasp", 0.5, 0.0, -0.001, 0.0)
    high = motion.plan_primitive("grasp", 0.5, 0.0, 0.6, 0.0)
    assert low.z == pytest.approx(cell.TABLE_Z + cell.MIN_TIP_HEIGHT)
    assert high.z == pytest.approx(cell.TABLE_Z + cell.MAX_TIP_HEIGHT)


def test_every_plan_ends_at_home_out_of_the_camera_view():
    retreat = motion.plan_primitive("push", 0.5, 0.0, 0.02, 1.0).retreat
    assert retreat.kind is StepKind.RETREAT
    assert retreat.position == pytest.approx(ur5_kinematics.HOME_TCP, abs=1e-3)


def test_steps_serialise_to_json_ready_dicts():
    record = motion.plan_primitive("grasp", 0.5, 0.0, 0.02, 0.0).steps[0].to_dict()
    assert record["kind"] == "approach" and isinstance(record["position"], list)


@pytest.mark.parametrize("request_, reason", [
    (("lift", 0.5, 0.0, 0.02, 0.0), "unknown primitive"),
    (("grasp", float("nan"), 0.0, 0.02, 0.0), "x is not finite"),
    (("grasp", 0.5, "a", 0.02, 0.0), "y is not a number"),
    (("grasp", 0.9, 0.0, 0.02, 0.0), "outside the workspace"),
    (("push", 0.5, 0.3, 0.02, 0.0), "outside the workspace"),
    (("grasp", 0.5, 0.0, -0.05, 0.0), "below the table"),
    (("grasp", 0.5, 0.0, 2.0, 0.0), "above the table"),
])
def test_invalid_primitives_are_refused_with_a_reason(request_, reason):
    assert reason in motion.validate_primitive(*request_)
    with pytest.raises(motion.PrimitiveRefused, match=reason):
        motion.plan_primitive(*request_)


def test_workspace_corners_at_the_highest_z_are_within_reach():
    for x in cell.WORKSPACE_X:
        for y in cell.WORKSPACE_Y:
            assert motion.validate_primitive("push", x, y, cell.MAX_TIP_HEIGHT, 0.0) is None


def test_a_pose_beyond_the_arm_reach_is_refused_even_inside_a_wider_workspace():
    reason = motion.validate_primitive("grasp", 0.95, 0.0, 0.02, 0.0, workspace_x=(0.2, 1.2))
    assert reason.startswith("out of the arm's reach")
    assert motion.validate_primitive("grasp", 0.6, 0.0, 0.02, 0.0, workspace_x=(0.2, 1.2)) is None


def test_run_plan_skips_the_rest_of_a_descent_after_a_guarded_stop():
    plan = motion.plan_primitive("grasp", 0.5, 0.0, 0.02, 0.0)
    phases = []
    run = motion.run_plan(plan.motion_steps, lambda step: step.kind is not StepKind.GUARDED,
                          phase=lambda name, progress: phases.append(name))
    assert [s.kind for s in run.executed] == [StepKind.APPROACH, StepKind.GRIPPER, StepKind.GUARDED,
                                              StepKind.GRIPPER, StepKind.LIFT]
    assert not run.reached and run.contact_stops == [plan.steps[2]]
    assert phases == ["approach", "open", "descend", "close", "lift"]  # each phase announced once


def test_run_plan_runs_every_step_when_nothing_is_touched():
    plan = motion.plan_primitive("push", 0.5, 0.0, 0.02, 0.0)
    run = motion.run_plan(plan.steps, lambda step: True)
    assert run.executed == list(plan.steps) and run.reached


def test_a_driver_refuses_a_goal_in_another_frame_or_of_an_unknown_kind():
    from impurity_common.enums import PrimitiveKind

    grasp = int(PrimitiveKind.GRASP)
    assert motion.goal_refusal(grasp, 0.5, 0.0, 0.02, 0.0, "") is None
    assert motion.goal_refusal(grasp, 0.5, 0.0, 0.02, 0.0, "base_link") is None
    assert "camera_link" in motion.goal_refusal(grasp, 0.5, 0.0, 0.02, 0.0, "camera_link")
    assert "camera_link" in motion.goal_refusal(grasp, 9.0, 0.0, 0.02, 0.0, "camera_link")  # frame first
    assert "kind 7" in motion.goal_refusal(7, 0.5, 0.0, 0.02, 0.0, "")
    assert motion.goal_refusal(grasp, 0.9, 0.0, 0.02, 0.0, "") == motion.validate_primitive(
        "grasp", 0.9, 0.0, 0.02, 0.0)


def test_the_arm_is_claimed_by_one_valid_goal_at_a_time_and_released_after_it():
    from impurity_common.enums import PrimitiveKind

    grasp = int(PrimitiveKind.GRASP)
    claim = motion.ArmClaim()
    assert "camera_link" in claim.refuse_or_claim(grasp, 0.5, 0.0, 0.02, 0.0, "camera_link")
    assert claim.refuse_or_claim(grasp, 0.5, 0.0, 0.02, 0.0, "") is None  # a refused goal claimed nothing
    assert claim.refuse_or_claim(grasp, 0.5, 0.0, 0.02, 0.0, "") == motion.ArmClaim.BUSY
    claim.release()
    assert claim.refuse_or_claim(grasp, 0.5, 0.0, 0.02, 0.0, "") is None


def test_the_drivers_own_check_comes_after_the_goal_check_and_claims_nothing():
    from impurity_common.enums import PrimitiveKind

    grasp = int(PrimitiveKind.GRASP)
    asked = []

    def lost() -> str:
        asked.append(True)
        return "driver_lost: the UR controller does not answer"

    claim = motion.ArmClaim()
    assert "workspace" in claim.refuse_or_claim(grasp, 9.0, 0.0, 0.02, 0.0, "", lost)
    assert asked == []  # an invalid goal is refused for itself, without asking the controller
    assert claim.refuse_or_claim(grasp, 0.5, 0.0, 0.02, 0.0, "", lost).startswith("driver_lost")
    assert claim.refuse_or_claim(grasp, 0.5, 0.0, 0.02, 0.0, "", lambda: None) is None


def test_of_many_threads_asking_at_once_exactly_one_claims_the_arm():
    import threading

    from impurity_common.enums import PrimitiveKind

    claim, start, answers = motion.ArmClaim(), threading.Barrier(8), []

    def ask() -> None:
        start.wait()
        answers.append(claim.refuse_or_claim(int(PrimitiveKind.PUSH), 0.5, 0.0, 0.02, 0.0, ""))

    threads = [threading.Thread(target=ask) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=10)
    assert sorted(answers, key=str) == [None] + [motion.ArmClaim.BUSY] * 7


def test_a_fixed_position_out_of_reach_or_below_the_table_is_named_as_such():
    assert motion.reach_problem((0.25, -0.35, 0.20)) is None  # the real driver's default bin
    assert "reach" in motion.reach_problem((1.5, 1.5, 0.2))
    assert "below the table" in motion.reach_problem((0.3, 0.0, -0.1))
