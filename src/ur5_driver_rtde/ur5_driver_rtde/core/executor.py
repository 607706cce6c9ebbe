"""Runs an ur5_motion.motion plan on the real arm and gripper (or their dry-run stand-ins).

The plan is the one the simulated UR5 executes; motion.run_plan does the stepping (phases, the end of a
descent after a guarded stop), and this module says what each step kind means on a UR5:

    APPROACH  gripper set to the step's width (not waited for); straight up to SAFE_TRAVEL_HEIGHT when
              lower; moveJ_IK (joint space) across to above the target at that height; moveL down to
              the approach pose (the simulated arm's go_to_start: linear up, joint move, linear down)
    GRIPPER   gripper.open(width, force) or gripper.close(force) (0 width), waiting if the step says so
    GUARDED   moveL, then the controller's contact detection; on a contact ur-rtde stops the arm and
              retracts to the first contact (core/arm.py), and the descent ends
    LINEAR    moveL;  LIFT: moveL straight up from the measured TCP;  STROKE: moveL at the measured height
    RETREAT   straight up to SAFE_TRAVEL_HEIGHT when lower, then moveJ to ur5_kinematics.HOME_JOINTS

After a grasp's lift, an object the gripper holds is carried to `bin_position` and released (the
simulator removes it instead; these commands carry phase "bin"). Speeds are the plan's times
`speed_scale` (<= 1 slows a first run down).

Errors end the primitive with a result, never an exception: a lost connection -> message
"driver_lost: ..." after one attempt to stop the arm; a cancel -> the arm stops, the gripper opens, the
TCP leaves upwards and the arm goes home (no further cancel checks); a refused or stuck move, a gripper
fault, or the controller leaving normal operation -> "motion failed: ..." with the arm stopped (e.g.
"motion failed: protective stop during moveL (safety mode 3 PROTECTIVE_STOP, robot mode 7 RUNNING)").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from impurity_common import cell
from ur5_motion import motion, ur5_kinematics
from ur5_motion.motion import StepKind

from .arm import DriverLost, MotionCancelled, MotionFailed, UrArm
from .gripper import Gripper, GripperError

DRIVER_LOST = "driver_lost"
CANCELLED = "cancelled"
MOTION_FAILED = "motion failed"
BIN_POSITION = (0.25, -0.35, 0.20)  # m, TCP in base_link where a held object is released (right of the
#                                     workspace, beside the home pose; set the cell's own in real_cell.yaml)


@dataclass
class ExecutionResult:
    """What the hardware knows after a primitive (the ExecutePrimitive result's fields)."""

    success: bool  # grasp: holding an object after the lift; push: the motion completed
    motion_completed: bool  # the whole plan ran (a guarded stop on contact still completes it)
    gripper_opening: float  # m between the fingers after the lift (grasp); -1 when not measured
    holding: bool
    message: str
    executed: list  # the plan's steps that ran, in order

    @property
    def driver_lost(self) -> bool:
        return self.message.startswith(DRIVER_LOST)


class PlanExecutor:
    def __init__(self, arm: UrArm, gripper: Gripper, log=None, speed_scale: float = 1.0,
                 bin_position=BIN_POSITION):
        if not 0.0 < speed_scale <= 1.0:
            raise ValueError(f"speed_scale must be in (0, 1], got {speed_scale}")
        self.arm, self.gripper, self.log = arm, gripper, log
        self.speed_scale = speed_scale
        self.bin_position = tuple(bin_position) if bin_position else None

    def _context(self, goal: int, index: int, phase: str, kind: str) -> None:
        if self.log is not None:
            self.log.context = {"goal": goal, "step": index, "phase": phase, "step_kind": kind}

    def execute(self, plan: motion.MotionPlan, goal: int = 0,
                phase: Callable[[str, float], None] = lambda name, progress: None,
                should_cancel: Callable[[], bool] = lambda: False) -> ExecutionResult:
        """Run the whole plan (up to and including the retreat); never raises for hardware faults."""
        executed = []
        indices = {id(step): i for i, step in enumerate(plan.steps)}

        def run_step(step: motion.Step) -> bool:
            self._context(goal, indices[id(step)], step.phase, step.kind.value)
            completed = self._run(step, should_cancel)
            executed.append(step)
            return completed

        opening, holding = -1.0, False
        try:
            run = motion.run_plan(plan.motion_steps, run_step, phase)
            if plan.kind == motion.GRASP:
                opening, holding = self.gripper.width(), self.gripper.holding()
                if holding and self.bin_position is not None:
                    phase("bin", 0.9)
                    self._release_in_bin(goal, len(plan.steps), should_cancel)
            phase("retreat", plan.retreat.progress)
            run_step(plan.retreat)
            phase("done", 1.0)
        except DriverLost as error:
            self.arm.stop()
            return ExecutionResult(False, False, opening, holding, f"{DRIVER_LOST}: {error}", executed)
        except MotionCancelled:
            message = self._leave_after_abort(goal, len(plan.steps) + 1, CANCELLED)
            return ExecutionResult(False, False, opening, False, message, executed)
        except (MotionFailed, GripperError) as error:
            self.arm.stop()
            lost = isinstance(error, GripperError) and not self.arm.connected()
            prefix = DRIVER_LOST if lost else MOTION_FAILED
            return ExecutionResult(False, False, opening, holding, f"{prefix}: {error}", executed)
        finally:
            if self.log is not None:
                self.log.context = {}
        note = "" if run.reached else " (descent stopped on contact)"
        if plan.kind == motion.PUSH:
            return ExecutionResult(True, True, -1.0, False, "pushed" + note, executed)
        if holding:
            message = f"holding an object ({opening * 1000:.0f} mm between the fingers)" + note
        else:
            message = f"nothing held (fingers at {opening * 1000:.0f} mm)" + note
        return ExecutionResult(holding, True, opening, holding, message, executed)

    # ------------------------------------------------------------------------------------ steps
    def _speed(self, step: motion.Step) -> float:
        return step.speed * self.speed_scale

    def _set_gripper(self, width: float, force: float, wait: bool) -> None:
        if width <= 0.0:
            self.gripper.close(force, wait)
        else:
            self.gripper.open(width, force, wait)

    def _run(self, step: motion.Step, should_cancel) -> bool:
        arm, speed, acceleration = self.arm, self._speed(step), step.acceleration
        if should_cancel():
            arm.stop()
            raise MotionCancelled(f"cancelled before {step.phase}")
        kind = step.kind
        if kind is StepKind.APPROACH:
            if step.width >= 0.0:
                self._set_gripper(step.width, cell.GRIP_FORCE, wait=False)
            self._travel_to(step.position, step.yaw, speed, acceleration, should_cancel)
        elif kind is StepKind.GRIPPER:
            self._set_gripper(step.width, step.grip_force, step.wait)
        elif kind is StepKind.GUARDED:
            return arm.move_linear(step.position, step.yaw, speed, acceleration,
                                   force_threshold=step.force_threshold, should_stop=should_cancel)
        elif kind is StepKind.LINEAR:
            arm.move_linear(step.position, step.yaw, speed, acceleration, should_stop=should_cancel)
        elif kind is StepKind.LIFT:
            here, _ = arm.tcp()
            arm.move_linear((here[0], here[1], step.position[2]), step.yaw, speed, acceleration,
                            should_stop=should_cancel)
        elif kind is StepKind.STROKE:
            here, _ = arm.tcp()
            arm.move_linear((step.position[0], step.position[1], here[2]), step.yaw, speed, acceleration,
                            should_stop=should_cancel)
        elif kind is StepKind.RETREAT:
            arm.up_to_travel_height(speed, acceleration, should_cancel)
            arm.move_joints(ur5_kinematics.HOME_JOINTS, should_cancel)
        else:
            raise MotionFailed(f"unknown step kind {kind!r}")
        return True

    def _travel_to(self, position, yaw, speed, acceleration, should_cancel) -> None:
        """Up to the travel height, across in joint space above the target, straight down (never through
        clutter)."""
        self.arm.up_to_travel_height(speed, acceleration, should_cancel)
        high = (position[0], position[1], max(cell.SAFE_TRAVEL_HEIGHT, position[2]))
        self.arm.move_joints_to_pose(high, yaw, should_cancel)
        if high[2] != position[2]:
            self.arm.move_linear(position, yaw, speed, acceleration, should_stop=should_cancel)

    def _release_in_bin(self, goal: int, index: int, should_cancel) -> None:
        self._context(goal, index, "bin", "bin")
        speed = cell.FREE_SPEED * self.speed_scale
        self._travel_to(self.bin_position, self.arm.tcp()[1], speed, cell.LINEAR_ACCELERATION, should_cancel)
        self.gripper.open(cell.GRASP_OPENING, cell.GRIP_FORCE, wait=True)

    def _leave_after_abort(self, goal: int, index: int, reason: str) -> str:
        """After a cancel: open, leave upwards at CONTACT_SPEED, go home; no further cancel checks."""
        self._context(goal, index, "abort", "abort")
        try:
            self.arm.stop()
            self.gripper.open(cell.GRASP_OPENING, cell.GRIP_FORCE, wait=True)
            here, yaw = self.arm.tcp()
            up = max(here[2], min(here[2] + cell.APPROACH_HEIGHT, cell.SAFE_TRAVEL_HEIGHT))
            self.arm.move_linear((here[0], here[1], up), yaw, cell.CONTACT_SPEED * self.speed_scale,
                                 cell.LINEAR_ACCELERATION)
            self.arm.up_to_travel_height(cell.FREE_SPEED * self.speed_scale, cell.LINEAR_ACCELERATION)
            self.arm.move_joints(ur5_kinematics.HOME_JOINTS)
        except DriverLost as error:
            self.arm.stop()
            return f"{DRIVER_LOST}: {error} (while leaving after: {reason})"
        except (MotionFailed, GripperError, MotionCancelled) as error:
            self.arm.stop()
            return f"{reason}; leaving failed: {error}"
        return reason
