"""The known product: what the product looked like before anything moved, from a view that showed no impurity.

In an invisible scene the first view shows product only (attention finds no target in it). After pushes the
region verifier sometimes calls a product piece an impurity; such pieces are coloured like much of the first
view, while a revealed impurity is coloured like almost none of it.

The known product is an impurity_common.colour.ProductReference of the view's object cells (attention's own
object threshold, density.occupied_height); attention.attend takes it as `known_product` and, while a heap
that could hide a target is left, passes over a region whose grown mask is coloured like more than
`AttentionParams.known_product_max_share` of it (ProductReference.share_near). Which view shows product only
is the picking loop's decision (core/picking.py of impurity_policy: the episode's first view, when attention
found no target in it); this module only builds the memory. "No target in the first view" is not
"product only": an impurity the verifier scored under its threshold would be remembered as product and passed
over while a heap is left, so the memory leaves out the view's near miss, the region a last look would take.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from impurity_common.colour import ProductReference
from impurity_common.enums import AttentionMode
from impurity_common.grid import HeightmapGrid

from .attention import AttentionParams, attend
from .verifier import MIN_SPREAD, default_verifier


def near_miss(color: np.ndarray, height: np.ndarray, params: AttentionParams = AttentionParams(),
              grid: HeightmapGrid = HeightmapGrid()) -> np.ndarray | None:
    """The grown mask (H, W) bool of the region attention would take in this view at the last look's
    threshold (the verifier's likeliest region, when its probability reaches the model's last_look), or
    None: no such region."""
    model = params.verifier or default_verifier()
    at_last_look = dataclasses.replace(model, threshold=model.last_look)
    looking = dataclasses.replace(params, verifier=at_last_look)
    looked = attend(color, height, looking, grid)
    return looked.target_mask if looked.mode == AttentionMode.TARGET else None


def known_product(color: np.ndarray, height: np.ndarray, params: AttentionParams = AttentionParams(),
                  grid: HeightmapGrid = HeightmapGrid()) -> ProductReference | None:
    """The known product from a colour heightmap (H, W, 3) uint8 and its height map (H, W) float m: the
    colours of its object cells (height > params.density.occupied_height; NaN is no object), at most
    colour.REFERENCE_CELLS of them, without the cells of near_miss (grid: the heightmap's, for that look).
    None when the view has no object cell; ValueError when the shapes differ."""
    height = np.nan_to_num(np.asarray(height, dtype=np.float64))
    whole = ProductReference.from_view(color, height, None, MIN_SPREAD, params.density.occupied_height)
    left_out = near_miss(color, height, params, grid) if whole is not None else None
    if left_out is None:
        return whole
    return ProductReference.from_view(color, height, left_out, MIN_SPREAD, params.density.occupied_height)
