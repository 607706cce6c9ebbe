"""The network's colour input in one appearance, whatever the scene's (issue 17; twenty-third session; the
candidate rule canonical_colours, in no preset: tested twice on tuning data and not adopted).

The push-grasp network learnt on the default palette first (blue product, red impurities) and was then
fine-tuned with a fifth of its scenes still in it. On tuning palettes it grasps a revealed target while
product still touches it, and the grasp closes on nothing, where on the default palette, same layouts, it
pushes first (docs/experiments.md, twenty-third section). Attention has already said which cells are the
target; the colour the network sees adds nothing to that but the palette. So each cell of the colour crop
is repainted in the default palette's colour for its class (target, product, table), scaled by how light
the cell is against its class's median: the shading of faces, edges and gaps stays, the hue goes.

Classes, from the observation alone: object cells are those above OBJECT_HEIGHT; in TARGET mode the target
is the mask, product the other object cells; in any other mode every object cell is product (an occluded
region's mask is all ones). The reference colours are the medians over the default palette's tuning scenes
at exposure x1 (`runs/perception/tuning.npz`, 70 scenes, calibrate_attention.py collect --split tuning):
product (37, 118, 201), target (234, 64, 42), table (160, 160, 160) RGB.
"""

from __future__ import annotations

import numpy as np

from .decision import OBJECT_HEIGHT  # m: cells higher than this are objects (what a grasp needs)

REFERENCE_RGB = {"target": (234.0, 64.0, 42.0), "product": (37.0, 118.0, 201.0),
                 "table": (160.0, 160.0, 160.0)}
MIN_INTENSITY = 1.0  # RGB mean below which a class's median counts as this (an all-black class)


def canonical_colours(color: np.ndarray, height: np.ndarray, mask: np.ndarray,
                      target_mode: bool) -> np.ndarray:
    """(S, S, 3) uint8 colour crop repainted in the default palette (module docstring). color (S, S, 3)
    uint8, height (S, S) m (NaN: table), mask (S, S) the attention mask (> 0: target in TARGET mode),
    target_mode: whether attention's mode is TARGET. Returns a new array; the input is not changed."""
    rgb = np.asarray(color, dtype=np.float32)
    intensity = rgb.mean(axis=-1)
    objects = np.nan_to_num(np.asarray(height, dtype=np.float32), nan=0.0) > OBJECT_HEIGHT
    target = objects & (np.asarray(mask) > 0) if target_mode else np.zeros_like(objects)
    classes = {"target": target, "product": objects & ~target, "table": ~objects}
    out = np.zeros_like(rgb)
    for name, cells in classes.items():
        if not cells.any():
            continue
        level = max(float(np.median(intensity[cells])), MIN_INTENSITY)
        out[cells] = np.asarray(REFERENCE_RGB[name], np.float32) * (intensity[cells] / level)[:, None]
    return np.clip(out + 0.5, 0, 255).astype(np.uint8)
