"""Hand-built height maps shared by the pose and rules specifications (224 x 224 px at 2 mm)."""

import numpy as np


def block(height: np.ndarray, centre, half_px: int, top: float) -> None:
    """A square block (2 half_px + 1 px wide) `top` m tall at heightmap pixel `centre`, in place."""
    height[centre[0] - half_px:centre[0] + half_px + 1, centre[1] - half_px:centre[1] + half_px + 1] = top


def covered_heap(top: float = 0.09) -> np.ndarray:
    """A 50 mm slab 41 px wide with a pile on its middle, centred in a 224 px map (crop origin 56, 56)."""
    height = np.zeros((224, 224), np.float32)
    block(height, (112, 112), 20, 0.05)
    block(height, (112, 112), 5, top)
    return height
