"""The paper's two motion primitives (section 3) in the simulator: the plan comes from
ur5_motion.motion (the one the real driver executes too), and its steps run on a Carrier
(gripper.py: the floating gripper or the simulated UR5).

grasp(x, y, z, yaw): start above, open to cell.GRASP_OPENING, descend (guarded), close across yaw,
                     lift >= 10 cm.
push(x, y, z, yaw):  close, start above, descend (guarded), move PUSH_LENGTH along yaw, lift.

Every executed step is appended to `carrier.executed_steps` (reset when a plan starts); the plan's
RETREAT step is recorded when the world sends the carrier home after the primitive (Carrier.go_home).
"""

from __future__ import annotations

from dataclasses import dataclass

from ur5_motion import motion
from ur5_motion.motion import (  # noqa: F401  (re-exported: the world and tests import them here)
    GRASP,
    KINDS,
    PUSH,
    StepKind,
    clamp_tip_height,
    clamp_to_workspace,
    validate_primitive,
)

from . import config
from .gripper import Carrier, MotionCancelled

GRIPPER_COMMAND_STEPS = 2  # physics steps after a gripper command that does not wait (width already set)


@dataclass
class PrimitiveOutcome:
    success: bool
    target_grasped: bool = False  # simulator truth
    object_id: int = -1  # simulator truth
    message: str = ""
    # What a real arm would know too (ExecutePrimitive's result): filled by the world when it has them.
    motion_completed: bool = True  # False: refused, cancelled or unreachable
    gripper_opening: float = -1.0  # m between the fingers after the lift (grasp); -1 not measured
    holding: bool = False  # something between the fingers after the lift


def execute_step(carrier: Carrier, step: motion.Step) -> bool:
    """Run one plan step on the carrier; False when a GUARDED step stopped on contact."""
    kind = step.kind
    if kind is StepKind.APPROACH:
        carrier.go_to_start(step.position, step.yaw, step.width)
    elif kind is StepKind.GRIPPER:
        settle = config.CLOSE_SETTLE_STEPS if step.wait else GRIPPER_COMMAND_STEPS
        carrier.move_fingers(step.width, steps=settle)
    elif kind is StepKind.GUARDED:
        return carrier.move_linear(step.position, step.yaw, step.speed, guarded=True,
                                   guard_force=step.force_threshold)
    elif kind is StepKind.LINEAR:
        carrier.move_linear(step.position, step.yaw, step.speed)
    elif kind is StepKind.LIFT:
        tip = carrier.tcp_position()
        carrier.move_linear((tip[0], tip[1], step.position[2]), step.yaw, step.speed)
    elif kind is StepKind.STROKE:
        tip = carrier.tcp_position()
        carrier.move_linear((step.position[0], step.position[1], tip[2]), step.yaw, step.speed)
    elif kind is StepKind.RETREAT:
        carrier.go_home()
    else:
        raise ValueError(f"unknown step kind {kind!r}")
    return True


def run_motion(carrier: Carrier, plan: motion.MotionPlan, phase,
               before_step=lambda step: None) -> motion.PlanRun:
    """Run the plan's steps up to the retreat on the carrier, recording them in carrier.executed_steps;
    the retreat is left pending for the world's go_home."""
    carrier.executed_steps = []
    carrier.pending_retreat = None

    def run_and_record(step):
        completed = execute_step(carrier, step)
        carrier.executed_steps.append(step)
        return completed

    run = motion.run_plan(plan.motion_steps, run_and_record, phase, before_step)
    carrier.pending_retreat = plan.retreat
    return run


def execute_grasp(carrier: Carrier, x, y, z, yaw, body_heights, phase=lambda name, progress: None):
    """Run the grasp plan. body_heights() -> {id: z}. Returns (lifted_id or -1, final opening, message)."""
    plan = motion.grasp_plan(x, y, z, yaw)
    before = {}

    def remember_heights(step):
        if step.kind is StepKind.GUARDED and not before:
            before.update(body_heights())  # after the fingers opened, before the descent

    run = run_motion(carrier, plan, phase, remember_heights)
    opening = carrier.opening()
    after = body_heights()
    lifted = [b for b in before if b in after and after[b] - before[b] >= config.GRASP_LIFT_SUCCESS]
    held = [b for b in lifted if carrier.touches(b)]
    note = "" if run.reached else " (descent stopped on contact)"
    if opening <= config.CLOSED_OPENING:
        return -1, opening, "fingers closed on nothing" + note
    if not held:
        return -1, opening, f"fingers stopped at {opening * 1000:.0f} mm but nothing was lifted" + note
    # Highest lifted body in contact: the one between the fingers.
    best = max(held, key=lambda b: after[b] - before[b])
    return best, opening, "lifted" + note


def execute_push(carrier: Carrier, x, y, z, yaw, phase=lambda name, progress: None) -> str:
    """Run the push plan; returns a message (empty when the descent ran its full length)."""
    run = run_motion(carrier, motion.push_plan(x, y, z, yaw), phase)
    return "" if run.reached else "descent stopped on contact; pushed from there"


__all__ = ["PrimitiveOutcome", "validate_primitive", "execute_grasp", "execute_push", "execute_step",
           "run_motion", "MotionCancelled", "GRASP", "PUSH", "KINDS"]
