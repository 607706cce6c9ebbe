"""One motion plan for the paper's two primitives (section 3), executed by the simulated UR5 and by the
real driver alike (pure Python, no rclpy, no simulator).

A primitive (kind, x, y, z, yaw in base_link; m, rad) becomes an ordered list of `Step`s, each a TCP
waypoint (position m, yaw rad about base_link +z: the grasp's closing axis or the push direction) with a
speed (m/s), an acceleration (m/s^2) and a kind saying how to run it:

    grasp: APPROACH above (gripper set to cell.GRASP_OPENING on the way), GRIPPER open, GUARDED descent
           (fast to SLOW_ZONE above z, then slow), GRIPPER close (waits), LIFT LIFT_HEIGHT >= 0.10 m,
           RETREAT home
    push:  APPROACH above (fingers closed on the way), GRIPPER close, GUARDED descent, STROKE of
           cell.PUSH_LENGTH along yaw (end clamped to the workspace), LINEAR up to APPROACH_HEIGHT above
           z, RETREAT home

The TCP is the centre between the fingertips' lower ends; the gripper frame is Rz(yaw) with z up, and
tool0 is cell.FLANGE_TO_TCP above the TCP (ur5_motion.ur5_kinematics). Every constant comes from
impurity_common.cell. `run_plan` is the one stepping logic (phases, skipping the rest of a descent
after a guarded stop, the record of executed steps); executors supply `execute_step(step) -> bool`.

    plan = plan_primitive("grasp", 0.5, 0.0, 0.02, 0.3)   # PrimitiveRefused(reason) if invalid
    run = run_plan(plan.motion_steps, execute_step, phase=feedback)
"""

from __future__ import annotations

import enum
import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

from impurity_common import cell, names
from impurity_common.enums import PrimitiveKind
from ur5_motion import ur5_kinematics

GRASP = "grasp"
PUSH = "push"
KINDS = (GRASP, PUSH)
ABSURD_Z = 1.0  # m above the table: a request this high is an error, not something to clamp
Z_BELOW_TABLE_TOLERANCE = 0.002  # m: heightmap noise may put z a hair under the table
SHOULDER_HEIGHT = ur5_kinematics.DH_D[0]  # m: the shoulder axis above base_link (reach is measured from it)


class StepKind(enum.StrEnum):
    """How an executor runs a step (its `phase` says what it is for)."""

    APPROACH = "approach"  # free move to `position` from wherever the TCP is, over the clutter: up to
    #                        SAFE_TRAVEL_HEIGHT when lower, across, straight down; the gripper is set to
    #                        `width` on the way
    GRIPPER = "gripper"  # set the fingers to `width` (0: close) with `grip_force`; `wait`: until they stop
    GUARDED = "guarded"  # straight line to `position` that stops when the gripper is pushed up harder
    #                      than `force_threshold` (contact) or reaches `position` (position threshold)
    LINEAR = "linear"  # straight line to `position`
    LIFT = "lift"  # straight up from the TCP's current x, y to `position`'s z (after a guarded stop the
    #                TCP stands above the plan's z)
    STROKE = "stroke"  # straight line at the TCP's current height to `position`'s x, y (a push from
    #                    wherever the descent stopped)
    RETREAT = "retreat"  # leave the camera's view: up to SAFE_TRAVEL_HEIGHT when lower, then home
    #                      (ur5_kinematics.HOME_JOINTS; `position` is HOME_TCP)


MOTION_KINDS = (StepKind.APPROACH, StepKind.GUARDED, StepKind.LINEAR, StepKind.LIFT, StepKind.STROKE,
                StepKind.RETREAT)


@dataclass(frozen=True)
class Step:
    """One waypoint of a motion plan. Units: m, rad, m/s, m/s^2, N."""

    kind: StepKind
    phase: str  # the ExecutePrimitive feedback phase: approach, open, descend, close, push, lift, retreat
    progress: float  # 0..1, feedback progress when the step starts
    position: tuple  # (x, y, z) of the TCP in base_link (m); for GRIPPER steps where the TCP stands
    yaw: float  # rad about base_link +z, the gripper's closing axis
    speed: float = 0.0  # m/s along the line (0 for GRIPPER steps)
    acceleration: float = 0.0  # m/s^2
    force_threshold: float = 0.0  # N, GUARDED steps: stop when pushed up harder than this
    width: float = -1.0  # m between the fingers, GRIPPER and APPROACH steps (-1: leave them)
    grip_force: float = 0.0  # N, GRIPPER steps
    wait: bool = False  # GRIPPER steps: wait until the fingers stop (closing on an object)

    def to_dict(self) -> dict:
        """JSON-ready: kind as its string, position as a list."""
        record = asdict(self)
        record["kind"] = self.kind.value
        record["position"] = [float(v) for v in self.position]
        return record


@dataclass(frozen=True)
class MotionPlan:
    """The steps of one primitive, and the request they came from (z after clamping)."""

    kind: str  # "grasp" or "push"
    x: float
    y: float
    z: float  # m, the TCP height the descent aims at (clamp_tip_height of the request)
    yaw: float
    steps: tuple  # of Step, the last one RETREAT

    @property
    def motion_steps(self) -> tuple:
        """Every step before the retreat: what the primitive itself does."""
        return tuple(s for s in self.steps if s.kind is not StepKind.RETREAT)

    @property
    def retreat(self) -> Step:
        return self.steps[-1]


class PrimitiveRefused(ValueError):
    """A primitive that cannot be executed; str() is the reason. Raised before any motion."""


@dataclass
class PlanRun:
    """What run_plan did: the steps executed in order, and the guarded steps that stopped on contact."""

    executed: list
    contact_stops: list

    @property
    def reached(self) -> bool:
        """True when every guarded descent ran to its position (no contact stop)."""
        return not self.contact_stops


# ------------------------------------------------------------------------------------ validation
def clamp_tip_height(z: float) -> float:
    """Fingertip height (m) kept in [table + MIN_TIP_HEIGHT, table + MAX_TIP_HEIGHT]."""
    return min(max(z, cell.TABLE_Z + cell.MIN_TIP_HEIGHT), cell.TABLE_Z + cell.MAX_TIP_HEIGHT)


def clamp_to_workspace(x: float, y: float, workspace_x=cell.WORKSPACE_X,
                       workspace_y=cell.WORKSPACE_Y) -> tuple:
    """(x, y) moved onto the nearest point of the workspace rectangle (m)."""
    return (min(max(x, workspace_x[0]), workspace_x[1]), min(max(y, workspace_y[0]), workspace_y[1]))


def tool0_distance_from_shoulder(position) -> float:
    """Distance (m) from the UR5's shoulder axis (SHOULDER_HEIGHT above base_link's origin) to tool0 when
    the TCP is at `position` with the gripper pointing down (tool0 is FLANGE_TO_TCP above the TCP)."""
    x, y, z = position
    return math.dist((x, y, z + cell.FLANGE_TO_TCP), (0.0, 0.0, SHOULDER_HEIGHT))



def reach_problem(position, reach: float = cell.UR5_REACH) -> str | None:
    """check= for a fixed TCP position (m, base_link) the arm must move to, e.g. the driver's bin: None, or
    what is wrong with it (below the table, or tool0 farther than `reach` m from the shoulder: the
    distance validate_primitive refuses a primitive's waypoints beyond)."""
    x, y, z = position
    if z < 0.0:
        return f"is below the table (z {z:.3f} m < 0)"
    distance = tool0_distance_from_shoulder(position)
    if distance > reach:
        return f"is out of the UR5's reach: tool0 {distance:.2f} m from the shoulder (at most {reach})"
    return None

def goal_refusal(kind: int, x: float, y: float, z: float, yaw: float, frame_id: str) -> str | None:
    """Why a driver refuses an ExecutePrimitive goal (Primitive.kind as its integer, position in m,
    yaw in rad, header.frame_id), or None: validate_primitive, and the position must be in
    base_link ("" is taken as base_link). A wrong frame is the reason given even when the values fail
    too. Both drivers (sim_cell, ur5_driver) ask this before anything moves."""
    try:
        label = PrimitiveKind(kind).label
    except ValueError:
        label = f"kind {kind}"  # validate_primitive refuses it by name
    reason = validate_primitive(label, x, y, z, yaw)
    if frame_id not in ("", names.BASE_FRAME):
        reason = f"position must be in {names.BASE_FRAME}, got frame '{frame_id}'"
    return reason



class ArmClaim:
    """A driver's hold on the arm: one primitive at a time, whichever thread asks (both drivers' goal
    callbacks). `refuse_or_claim` runs goal_refusal, then the driver's own check, then takes the arm;
    `release` gives it back when the primitive has ended, however it ended."""

    BUSY = "busy: another primitive is running"

    def __init__(self):
        self._lock = threading.Lock()
        self._busy = False

    def refuse_or_claim(self, kind: int, x: float, y: float, z: float, yaw: float, frame_id: str,
                        unavailable: Callable[[], str | None] | None = None) -> str | None:
        """Why the goal is refused (goal_refusal's reason; else unavailable()'s, e.g. a lost controller;
        else BUSY while another primitive holds the arm), or None: the arm is now claimed for this goal and
        must be released."""
        reason = goal_refusal(kind, x, y, z, yaw, frame_id)
        if reason is None and unavailable is not None:
            reason = unavailable()
        if reason is not None:
            return reason
        with self._lock:
            if self._busy:
                return self.BUSY
            self._busy = True
        return None

    def release(self) -> None:
        with self._lock:
            self._busy = False

def validate_primitive(kind: str, x: float, y: float, z: float, yaw: float, *,
                       workspace_x=cell.WORKSPACE_X, workspace_y=cell.WORKSPACE_Y,
                       reach: float = cell.UR5_REACH) -> str | None:
    """None when the request can be executed, else the reason it is refused (nothing moves).

    Refused: an unknown kind; a value that is not a finite number; (x, y) outside the workspace
    rectangle (m, base_link); z below the table (beyond Z_BELOW_TABLE_TOLERANCE) or more than ABSURD_Z
    above it; any waypoint of the plan whose tool0 lies farther than `reach` (m) from the shoulder.
    A z between table and ABSURD_Z is clamped (clamp_tip_height), never refused."""
    if kind not in KINDS:
        return f"unknown primitive {kind!r} (expected one of {KINDS})"
    for name, value in {"x": x, "y": y, "z": z, "yaw": yaw}.items():
        try:
            finite = math.isfinite(float(value))
        except (TypeError, ValueError):
            return f"{name} is not a number: {value!r}"
        if not finite:
            return f"{name} is not finite ({value})"
    if not (workspace_x[0] <= x <= workspace_x[1] and workspace_y[0] <= y <= workspace_y[1]):
        return (f"({x:.3f}, {y:.3f}) is outside the workspace x in [{workspace_x[0]}, "
                f"{workspace_x[1]}], y in [{workspace_y[0]}, {workspace_y[1]}]")
    if z < cell.TABLE_Z - Z_BELOW_TABLE_TOLERANCE:
        return f"z = {z:.3f} m is below the table (z = {cell.TABLE_Z})"
    if z > cell.TABLE_Z + ABSURD_Z:
        return f"z = {z:.3f} m is more than {ABSURD_Z} m above the table"
    plan = _build(kind, float(x), float(y), float(z), float(yaw), workspace_x, workspace_y)
    for step in plan.motion_steps:
        distance = tool0_distance_from_shoulder(step.position)
        if distance > reach:
            p = step.position
            return (f"out of the arm's reach: the {step.phase} waypoint ({p[0]:.3f}, {p[1]:.3f}, "
                    f"{p[2]:.3f}) puts tool0 {distance:.3f} m from the shoulder (reach {reach} m)")
    return None


# ------------------------------------------------------------------------------------ plans
def _home() -> tuple:
    pose = ur5_kinematics.tcp_pose(ur5_kinematics.HOME_JOINTS)
    return tuple(float(v) for v in pose[:3, 3]), math.atan2(pose[1, 0], pose[0, 0])


HOME_POSITION, HOME_YAW = _home()  # TCP at ur5_kinematics.HOME_JOINTS: parked out of the camera's view


def retreat_step() -> Step:
    """Leave the camera's view (last step of every plan; also what an aborted motion ends with)."""
    return Step(StepKind.RETREAT, "retreat", 0.95, HOME_POSITION, HOME_YAW, cell.FREE_SPEED,
                cell.LINEAR_ACCELERATION)


def _descent(x: float, y: float, z: float, yaw: float) -> list:
    """Guarded descent: fast to SLOW_ZONE above z, then at CONTACT_SPEED to z."""
    a, f = cell.LINEAR_ACCELERATION, cell.GUARD_FORCE
    return [Step(StepKind.GUARDED, "descend", 0.3, (x, y, z + cell.SLOW_ZONE), yaw, cell.FREE_SPEED, a, f),
            Step(StepKind.GUARDED, "descend", 0.3, (x, y, z), yaw, cell.CONTACT_SPEED, a, f)]


def grasp_plan(x: float, y: float, z: float, yaw: float) -> MotionPlan:
    """The grasp's steps (no validation: see plan_primitive). z is clamped by clamp_tip_height."""
    z = clamp_tip_height(z)
    above = (x, y, z + cell.APPROACH_HEIGHT)
    a, force = cell.LINEAR_ACCELERATION, cell.GRIP_FORCE
    steps = [Step(StepKind.APPROACH, "approach", 0.0, above, yaw, cell.FREE_SPEED, a,
                  width=cell.GRASP_OPENING),
             Step(StepKind.GRIPPER, "open", 0.2, above, yaw, width=cell.GRASP_OPENING, grip_force=force),
             *_descent(x, y, z, yaw),
             Step(StepKind.GRIPPER, "close", 0.5, (x, y, z), yaw, width=0.0, grip_force=force, wait=True),
             Step(StepKind.LIFT, "lift", 0.7, (x, y, z + cell.LIFT_HEIGHT), yaw, cell.LIFT_SPEED, a),
             retreat_step()]
    return MotionPlan(GRASP, x, y, z, yaw, tuple(steps))


def push_plan(x: float, y: float, z: float, yaw: float, workspace_x=cell.WORKSPACE_X,
              workspace_y=cell.WORKSPACE_Y) -> MotionPlan:
    """The push's steps (no validation: see plan_primitive): PUSH_LENGTH along yaw from (x, y), the
    end clamped to the workspace. z is clamped by clamp_tip_height."""
    z = clamp_tip_height(z)
    end_x, end_y = clamp_to_workspace(x + cell.PUSH_LENGTH * math.cos(yaw),
                                      y + cell.PUSH_LENGTH * math.sin(yaw), workspace_x, workspace_y)
    above = (x, y, z + cell.APPROACH_HEIGHT)
    a = cell.LINEAR_ACCELERATION
    steps = [Step(StepKind.APPROACH, "approach", 0.0, above, yaw, cell.FREE_SPEED, a, width=0.0),
             Step(StepKind.GRIPPER, "close", 0.2, above, yaw, width=0.0, grip_force=cell.GRIP_FORCE),
             *_descent(x, y, z, yaw),
             Step(StepKind.STROKE, "push", 0.5, (end_x, end_y, z), yaw, cell.CONTACT_SPEED, a),
             Step(StepKind.LINEAR, "lift", 0.8, (end_x, end_y, z + cell.APPROACH_HEIGHT), yaw,
                  cell.FREE_SPEED, a),
             retreat_step()]
    return MotionPlan(PUSH, x, y, z, yaw, tuple(steps))


def _build(kind, x, y, z, yaw, workspace_x=cell.WORKSPACE_X, workspace_y=cell.WORKSPACE_Y) -> MotionPlan:
    if kind == GRASP:
        return grasp_plan(x, y, z, yaw)
    return push_plan(x, y, z, yaw, workspace_x, workspace_y)


def plan_primitive(kind: str, x: float, y: float, z: float, yaw: float, **limits) -> MotionPlan:
    """Validated plan for a primitive (m, rad, base_link). Raises PrimitiveRefused with the reason from
    validate_primitive (limits: workspace_x, workspace_y, reach) before anything moves."""
    reason = validate_primitive(kind, x, y, z, yaw, **limits)
    if reason is not None:
        raise PrimitiveRefused(reason)
    return _build(kind, float(x), float(y), float(z), float(yaw),
                  limits.get("workspace_x", cell.WORKSPACE_X), limits.get("workspace_y", cell.WORKSPACE_Y))


# ------------------------------------------------------------------------------------ running a plan
def run_plan(steps: Sequence[Step], execute_step: Callable[[Step], bool],
             phase: Callable[[str, float], None] = lambda name, progress: None,
             before_step: Callable[[Step], None] = lambda step: None) -> PlanRun:
    """Run `steps` in order through `execute_step(step)`, which returns False when a GUARDED step stopped
    on contact (True otherwise). A guarded stop ends the descent: the GUARDED steps right after it are
    skipped. `phase(name, progress)` is called when a step starts a new phase; `before_step(step)` before
    each executed step. Exceptions from execute_step (cancel, lost connection) propagate; the PlanRun
    then is not returned, so executors that need the partial record keep their own."""
    run = PlanRun(executed=[], contact_stops=[])
    current_phase, descent_stopped = None, False
    for step in steps:
        if step.kind is not StepKind.GUARDED:
            descent_stopped = False
        elif descent_stopped:
            continue
        if step.phase != current_phase:
            current_phase = step.phase
            phase(step.phase, step.progress)
        before_step(step)
        completed = execute_step(step)
        run.executed.append(step)
        if step.kind is StepKind.GUARDED and not completed:
            descent_stopped = True
            run.contact_stops.append(step)
    return run


__all__ = ["GRASP", "PUSH", "KINDS", "StepKind", "Step", "MotionPlan", "PlanRun", "PrimitiveRefused",
           "validate_primitive", "clamp_tip_height", "clamp_to_workspace", "grasp_plan", "push_plan",
           "plan_primitive", "run_plan", "retreat_step", "tool0_distance_from_shoulder", "HOME_POSITION",
           "HOME_YAW", "MOTION_KINDS"]
