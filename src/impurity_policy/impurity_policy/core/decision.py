"""From 32 Q maps to one action: the policy's input state, the valid-action masks, the argmax and
VPG's epsilon-greedy exploration (paper section 5.2: the action with the highest Q value over both
primitives, 16 rotations and every pixel). Pure numpy; used by the runtime policy and the trainer.

Shapes: a state's crops are (S, S) (S = 112 for attention crops, 224 for full-heightmap methods); Q maps
are (R, 2, S, S) with R = 16 rotations and index 0 = push, 1 = grasp (network.PUSH / GRASP).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .network import GRASP, PUSH, valid_action_mask

OBJECT_HEIGHT = 0.01  # m: grasps are only considered where the height crop shows something this tall


@dataclass
class State:
    """The policy's input for one decision: attention crops (112^2)."""

    color: np.ndarray  # (S, S, 3) uint8
    height: np.ndarray  # (S, S) float32 m
    mask: np.ndarray  # (S, S) uint8


@dataclass
class Decision:
    """One chosen action in crop coordinates."""

    primitive: int  # PUSH / GRASP
    rotation: int
    pixel: tuple  # (row, col) in the crop
    q_value: float
    explored: bool = False


def action_masks(state: State, crop_origin=None, heightmap_shape=None, allowed=(PUSH, GRASP),
                 grasp_needs_object: bool = True) -> np.ndarray:
    """(2, S, S) bool: where each primitive may act. Pixels inside the crop's inscribed disk (every
    rotation sees them), inside the heightmap when the crop hangs over its edge, grasps only on
    objects (optional), and no primitive that is not `allowed`."""
    size = state.mask.shape[0]
    base = valid_action_mask(size)
    if crop_origin is not None and heightmap_shape is not None:
        rows = np.arange(size)[:, None] + crop_origin[0]
        cols = np.arange(size)[None, :] + crop_origin[1]
        base = base & (rows >= 0) & (rows < heightmap_shape[0]) & (cols >= 0) & (cols < heightmap_shape[1])
    masks = np.zeros((2, size, size), dtype=bool)
    if PUSH in allowed:
        masks[PUSH] = base
    if GRASP in allowed:
        masks[GRASP] = base & (np.nan_to_num(state.height) > OBJECT_HEIGHT) if grasp_needs_object else base
        if not masks[GRASP].any():
            masks[GRASP] = base
    return masks


def best_action(q: np.ndarray, masks: np.ndarray, primitives=(PUSH, GRASP)) -> Decision:
    """Argmax of Q maps (R, 2, S, S) over the masked pixels of the given primitives."""
    best = None
    for primitive in primitives:
        if not masks[primitive].any():
            continue
        values = np.where(masks[primitive][None], q[:, primitive], -np.inf)
        flat = int(np.argmax(values))
        rotation, row, col = np.unravel_index(flat, values.shape)
        value = float(values[rotation, row, col])
        if value == -np.inf:  # every action of this primitive ruled out (rules.TriedActions, clearance)
            continue
        if best is None or value > best.q_value:
            best = Decision(primitive, int(rotation), (int(row), int(col)), value)
    if best is None:
        raise ValueError("no valid action: every primitive is masked out")
    return best


def epsilon_greedy(q: np.ndarray, masks: np.ndarray, allowed, epsilon: float,
                   rng: np.random.Generator) -> Decision:
    """VPG's exploration: with probability epsilon the primitive is drawn at random (among the allowed
    ones), and its best pixel and rotation are taken; else the overall argmax."""
    allowed = [p for p in allowed if np.isfinite(np.where(masks[p][None], q[:, p], -np.inf)).any()]
    if len(allowed) > 1 and rng.random() < epsilon:
        decision = best_action(q, masks, (allowed[int(rng.integers(len(allowed)))],))
        decision.explored = True
        return decision
    return best_action(q, masks, allowed)
