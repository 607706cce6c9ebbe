"""The paper's two motion primitives (section 3), written once against the Carrier interface.

grasp(x, y, z, yaw): start above, open to cell.GRASP_OPENING, descend (guarded), close across yaw,
                     lift >= 10 cm.
push(x, y, z, yaw):  close, start above, descend (guarded), move PUSH_LENGTH along yaw, lift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from impurity_common import cell

from . import config
from .gripper import Carrier, MotionCancelled

GRASP = "grasp"
PUSH = "push"
KINDS = (GRASP, PUSH)
MAX_Z = 0.15  # m above the table: blocks are < 0.1 m; higher z is clamped to this (arm reach)
ABSURD_Z = 1.0  # m above the table: a request this high is an error, not something to clamp
Z_BELOW_TABLE_TOLERANCE = 0.002  # m: heightmap noise may put z a hair under the table


@dataclass
class PrimitiveOutcome:
    success: bool
    target_grasped: bool = False
    object_id: int = -1
    message: str = ""


def validate_primitive(kind: str, x: float, y: float, z: float, yaw: float) -> str | None:
    """None when the request can be executed, else the reason it is refused (no motion happens)."""
    if kind not in KINDS:
        return f"unknown primitive {kind!r} (expected one of {KINDS})"
    values = {"x": x, "y": y, "z": z, "yaw": yaw}
    for name, value in values.items():
        try:
            finite = math.isfinite(float(value))
        except (TypeError, ValueError):
            return f"{name} is not a number: {value!r}"
        if not finite:
            return f"{name} is not finite ({value})"
    if not cell.in_workspace(x, y):
        return (f"({x:.3f}, {y:.3f}) is outside the workspace x in [{cell.WORKSPACE_X[0]}, "
                f"{cell.WORKSPACE_X[1]}], y in [{cell.WORKSPACE_Y[0]}, {cell.WORKSPACE_Y[1]}]")
    if z < cell.TABLE_Z - Z_BELOW_TABLE_TOLERANCE:
        return f"z = {z:.3f} m is below the table (z = {cell.TABLE_Z})"
    if z > cell.TABLE_Z + ABSURD_Z:
        return f"z = {z:.3f} m is more than {ABSURD_Z} m above the table"
    return None


def clamp_tip_height(z: float) -> float:
    return min(max(z, cell.TABLE_Z + config.MIN_TIP_HEIGHT), cell.TABLE_Z + MAX_Z)


def clamp_to_workspace(x: float, y: float) -> tuple:
    return (min(max(x, cell.WORKSPACE_X[0]), cell.WORKSPACE_X[1]),
            min(max(y, cell.WORKSPACE_Y[0]), cell.WORKSPACE_Y[1]))


def descend(carrier: Carrier, x, y, z, yaw) -> bool:
    """Guarded descent: fast to SLOW_ZONE above z, then slow; False when stopped on contact."""
    if not carrier.move_linear((x, y, z + config.SLOW_ZONE), yaw, config.FREE_SPEED, guarded=True):
        return False
    return carrier.move_linear((x, y, z), yaw, config.CONTACT_SPEED, guarded=True)


def execute_grasp(carrier: Carrier, x, y, z, yaw, body_heights, phase=lambda name, progress: None):
    """Run the grasp motion. body_heights() -> {id: z}. Returns (lifted_id or -1, final opening, message)."""
    z = clamp_tip_height(z)
    above = (x, y, z + config.APPROACH_HEIGHT)
    phase("approach", 0.0)
    carrier.go_to_start(above, yaw, cell.GRASP_OPENING)
    phase("open", 0.2)
    carrier.move_fingers(cell.GRASP_OPENING, steps=2)
    before = body_heights()
    phase("descend", 0.3)
    reached = descend(carrier, x, y, z, yaw)
    phase("close", 0.5)
    opening = carrier.move_fingers(0.0)
    phase("lift", 0.7)
    tip = carrier.tcp_position()
    carrier.move_linear((tip[0], tip[1], z + config.LIFT_HEIGHT), yaw, config.LIFT_SPEED)
    opening = carrier.opening()
    after = body_heights()
    lifted = [b for b in before if b in after and after[b] - before[b] >= config.GRASP_LIFT_SUCCESS]
    held = [b for b in lifted if carrier.touches(b)]
    note = "" if reached else " (descent stopped on contact)"
    if opening <= config.CLOSED_OPENING:
        return -1, opening, "fingers closed on nothing" + note
    if not held:
        return -1, opening, f"fingers stopped at {opening * 1000:.0f} mm but nothing was lifted" + note
    # Highest lifted body in contact: the one between the fingers.
    best = max(held, key=lambda b: after[b] - before[b])
    return best, opening, "lifted" + note


def execute_push(carrier: Carrier, x, y, z, yaw, phase=lambda name, progress: None) -> str:
    """Run the push motion; returns a message (empty when the push ran its full length)."""
    z = clamp_tip_height(z)
    end_x, end_y = clamp_to_workspace(x + cell.PUSH_LENGTH * math.cos(yaw),
                                      y + cell.PUSH_LENGTH * math.sin(yaw))
    phase("approach", 0.0)
    carrier.go_to_start((x, y, z + config.APPROACH_HEIGHT), yaw, 0.0)
    phase("close", 0.2)
    carrier.move_fingers(0.0, steps=2)
    phase("descend", 0.3)
    reached = descend(carrier, x, y, z, yaw)
    tip = carrier.tcp_position()
    phase("push", 0.5)
    carrier.move_linear((end_x, end_y, tip[2]), yaw, config.CONTACT_SPEED)
    phase("lift", 0.8)
    carrier.move_linear((end_x, end_y, z + config.APPROACH_HEIGHT), yaw, config.FREE_SPEED)
    return "" if reached else "descent stopped on contact; pushed from there"


__all__ = ["PrimitiveOutcome", "validate_primitive", "execute_grasp", "execute_push", "MotionCancelled",
           "GRASP", "PUSH", "KINDS"]
