"""Scene change between two height maps (VPG's change detection, paper 6.3.2): a pixel changed when
its height moved by 0.01-0.3 m; a scene changed when more than tau = 300 pixels did. Used by the
test-time memory of tried actions (rules) and by the No-T ablation's push reward (impurity_learning.tcdd).
"""

from __future__ import annotations

import numpy as np

CHANGE_PIXELS_TAU = 300  # px
CHANGE_HEIGHT_RANGE = (0.01, 0.3)  # m: a pixel "changed" when its height moved by this much (VPG)


def changed_pixels(height_before: np.ndarray, height_after: np.ndarray,
                   height_range: tuple = CHANGE_HEIGHT_RANGE) -> int:
    diff = np.abs(np.nan_to_num(height_after) - np.nan_to_num(height_before))
    return int(np.count_nonzero((diff > height_range[0]) & (diff < height_range[1])))
