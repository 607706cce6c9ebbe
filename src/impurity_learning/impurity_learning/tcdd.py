"""Target-Centric Dispersion Degree (paper eqs. (2)-(3)) and the push/grasp rewards (section 5.2.3).

    d(p_t, p_j) = min(||p_t - p_j||_2, eta)                       (2)
    alpha_t     = sum_{j != t} d(p_t, p_j) / ((K - 1) eta)         (3)

with p the objects' centres in the table plane (x, y in base_link), K the number of objects in the
scene (target included) and eta the gripper's finger opening (cell.GRASP_OPENING, the pre-grasp
width). alpha_t = 1: no object within eta of the target, which can then be grasped without disturbing
anything.

Rewards: a grasp earns 1 when it lifts a target; a push earns 0.5 when it raised alpha by more than
delta = 0.005; everything else 0. The No-T ablation replaces the push rule with VPG's change
detection: more than tau = 300 heightmap pixels changed, reward 1 (paper 6.3.2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impurity_common import cell
from impurity_policy.core.change import CHANGE_PIXELS_TAU, changed_pixels

GRASP_TARGET_REWARD = 1.0
PUSH_TCDD_REWARD = 0.5
TCDD_DELTA = 0.005  # paper: ignore alpha changes below this (noise)
NO_T_PUSH_REWARD = 1.0  # paper 6.3.2: "the push reward is set to 1"


def tcdd(target_xy, other_xy, eta: float = cell.GRASP_OPENING) -> float:
    """alpha_t for one target at `target_xy` among the other objects' centres `other_xy` (K-1, 2).

    A target alone in the scene (K = 1) is isolated: 1.0.
    """
    if eta <= 0:
        raise ValueError(f"eta must be > 0, got {eta}")
    others = np.asarray(other_xy, dtype=np.float64).reshape(-1, 2)
    if len(others) == 0:
        return 1.0
    distances = np.linalg.norm(others - np.asarray(target_xy, dtype=np.float64).reshape(1, 2), axis=1)
    return float(np.minimum(distances, eta).sum() / (len(others) * eta))


def tcdd_of(target_id: int, positions: dict, eta: float = cell.GRASP_OPENING) -> float:
    """alpha of `target_id` given {object id: (x, y[, z])} of every object in the scene."""
    target = positions[target_id]
    others = [p[:2] for oid, p in positions.items() if oid != target_id]
    return tcdd(target[:2], others, eta)


def grasp_reward(target_grasped: bool) -> float:
    return GRASP_TARGET_REWARD if target_grasped else 0.0


def push_reward_tcdd(alpha_before: float, alpha_after: float, delta: float = TCDD_DELTA) -> float:
    return PUSH_TCDD_REWARD if alpha_after - alpha_before > delta else 0.0


def push_reward_change(height_before: np.ndarray, height_after: np.ndarray,
                       tau: int = CHANGE_PIXELS_TAU) -> float:
    """No-T ablation: VPG-style scene change detection on the full height maps."""
    return NO_T_PUSH_REWARD if changed_pixels(height_before, height_after) > tau else 0.0


@dataclass(frozen=True)
class PushOutcome:
    """What the trainer logs about one push: alpha before/after (NaN when no target was tracked)."""

    alpha_before: float
    alpha_after: float
    reward: float


def tcdd_push_outcome(target_id: int | None, before: dict, after: dict, in_workspace,
                      eta: float = cell.GRASP_OPENING, delta: float = TCDD_DELTA) -> PushOutcome:
    """Push reward for the attended target `target_id`, object positions {id: (x, y, z)} before and
    after the push. Objects that left the workspace count as far away (pushed clear); the target
    itself leaving the workspace earns nothing (guard against VPG's "push everything away", #16)."""
    if target_id is None or target_id not in before or target_id not in after:
        return PushOutcome(float("nan"), float("nan"), 0.0)
    if not in_workspace(*after[target_id][:2]):
        return PushOutcome(tcdd_of(target_id, before, eta), float("nan"), 0.0)
    alpha_before = tcdd_of(target_id, before, eta)
    alpha_after = tcdd_of(target_id, {oid: p for oid, p in after.items() if oid in before}, eta)
    return PushOutcome(alpha_before, alpha_after, push_reward_tcdd(alpha_before, alpha_after, delta))
