"""Hand-built height maps shared by the pose and rules specifications (224 x 224 px at 2 mm), and the
target observations and one-rule decisions built on them."""

import math

import numpy as np

from impurity_common import cell
from impurity_common.grid import HeightmapGrid
from impurity_policy.core.policy import Observation
from impurity_policy.core.pose import PoseRules
from impurity_policy.core.rules import RulePipeline

CROP = 112  # px, the policy's crop


def block(height: np.ndarray, centre, half_px: int, top: float) -> None:
    """A square block (2 half_px + 1 px wide) `top` m tall at heightmap pixel `centre`, in place."""
    height[centre[0] - half_px:centre[0] + half_px + 1, centre[1] - half_px:centre[1] + half_px + 1] = top


def covered_heap(top: float = 0.09) -> np.ndarray:
    """A 50 mm slab 41 px wide with a pile on its middle, centred in a 224 px map (crop origin 56, 56)."""
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 20, 0.05)
    block(height, (112, 112), 5, top)
    return height


def crop_observation(mode, height_crop: np.ndarray, mask: np.ndarray) -> Observation:
    """An observation in attention `mode` of a CROP px crop at origin (56, 56) of a 224 px map that is flat
    outside it, its colour a uniform grey; height_crop (m) and mask (uint8, > 0: the target) CROP x CROP."""
    height = np.zeros((224, 224), np.float32)
    height[56:56 + CROP, 56:56 + CROP] = height_crop
    return Observation(mode, np.full((CROP, CROP, 3), 150, np.uint8), height_crop, mask, (56, 56), height,
                       HeightmapGrid())


def kept_by(rule: str, obs: Observation, q: np.ndarray | None = None) -> np.ndarray:
    """(R, 2, CROP, CROP) bool: the actions the one rule `rule` leaves on Q maps q (default all 0)."""
    q = np.zeros((cell.NUM_ROTATIONS, 2, CROP, CROP), np.float32) if q is None else q
    valid = np.ones((2, CROP, CROP), bool)
    return np.isfinite(RulePipeline([rule]).apply(q, obs, valid, PoseRules(), obs.grid))


def block_top(profile, crest_yaw=math.pi / 2, width_px=24, length_px=28, height=0.036):
    """(heights (S, S) m, mask (S, S) uint8) of a block at the crop's centre whose cross-section across
    `crest_yaw` is `profile(v)` (v: -1 ... 1 across the block, returns 0 ... 1), unchanged along it."""
    rows, cols = np.mgrid[:CROP, :CROP].astype(np.float64) - CROP / 2
    along = cols * math.cos(crest_yaw) + rows * math.sin(crest_yaw)
    across = -cols * math.sin(crest_yaw) + rows * math.cos(crest_yaw)
    inside = (np.abs(along) <= length_px / 2) & (np.abs(across) <= width_px / 2)
    v = np.clip(across / (width_px / 2), -1.0, 1.0)
    return np.where(inside, height * profile(v), 0.0).astype(np.float32), (inside * 255).astype(np.uint8)


def prism(v):
    """An upright triangular prism: two faces meeting in a central crest."""
    return 1.0 - np.abs(v)


def half_cylinder(v):
    """A half cylinder lying on its flat face."""
    return np.sqrt(1.0 - v ** 2)


def lying_cylinder(v):
    return 0.5 + 0.5 * np.sqrt(1.0 - v ** 2)  # seen from above: its outline stands a radius up


def flat(v):
    """A flat top (a cube or slab)."""
    return np.ones_like(v)


def tilted(v):
    return 0.6 + 0.4 * v  # a flat face falling one way


def leaning(v):
    return np.where(v < 0.4, 0.3 + 0.7 * (v + 1.0) / 1.4, 1.0 - 0.5 * (v - 0.4) / 0.6)  # crest off the middle
