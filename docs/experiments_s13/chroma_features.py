"""Thirteenth session, tuning palettes only: do shading-free chromaticity features of a candidate region add
what the verifier's twelve miss? The subtle misses on fresh tuning palettes are impurities a little off the
product's hue (a pinker block among tan ones): the colour contrast and off-colour share read RGB, where a
shaded face of the product spreads further than that hue step. Candidate features, per region m against the
product P (verifier.region_features' P), on cells with no channel clipped and intensity >= 2 x
CHROMA_MIN_INTENSITY, chromaticity c = (RG / I, BY / I) (saliency.opponent_chromaticity):
- chroma_distance: log(1 + |median c over m - median c over P| / spread), spread per axis the product's
  median absolute deviation (floor CHROMA_FLOOR);
- chroma_density: log(1e-3 + share of P's cells whose c lies within one spread-scaled unit of m's median c):
  how common m's hue is on the product.

    python docs/experiments_s13/chroma_features.py cv                 # palette-grouped CV, 12 vs 14 features
    python docs/experiments_s13/chroma_features.py fresh 500 600      # fitted on all, on fresh tuning sets

Rows cached in runs/s13/chroma_<name>.npz.
"""
import math
import pathlib
import sys

import cv2
import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
sys.path.insert(0, "docs/experiments_s13")
import nonlinear  # noqa: E402

from impurity_attention.core.attention import AttentionParams, salient_regions, scene_maps  # noqa: E402
from impurity_attention.core.saliency import CHROMA_MIN_INTENSITY, opponent_chromaticity  # noqa: E402
from impurity_attention.core.verifier import PRODUCT_MARGIN, SATURATION, TOP_REGIONS, candidate_features  # noqa: E402

CACHE = pathlib.Path("runs/s13")
CHROMA_FLOOR = 0.01
NEW = ("chroma_distance", "chroma_density")


def chroma_features(color, objects, region) -> np.ndarray:
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * PRODUCT_MARGIN + 1,) * 2)
    product = objects & ~(cv2.dilate(region.astype(np.uint8), kernel) > 0)
    if not product.any():
        product = objects & ~region
    planes = opponent_chromaticity(color)
    usable = np.all(color < SATURATION, axis=-1) & (planes[..., 0] >= 2 * CHROMA_MIN_INTENSITY)
    own, reference = planes[region & usable][:, 1:], planes[product & usable][:, 1:]
    if len(own) < 5 or len(reference) < 5:
        return np.array([0.0, 0.0])
    centre = np.median(reference, axis=0)
    spread = np.maximum(np.median(np.abs(reference - centre), axis=0), CHROMA_FLOOR)
    mine = np.median(own, axis=0)
    distance = float(np.linalg.norm((mine - centre) / spread))
    near = np.linalg.norm((reference - mine) / spread, axis=1) <= 1.0
    return np.array([math.log1p(distance), math.log(1e-3 + float(np.mean(near)))])


def rows(name: str, records_of) -> tuple:
    path = CACHE / f"chroma_{name}.npz"
    if path.exists():
        data = np.load(path)
        return tuple(data[k] for k in ("features", "on", "scene", "group", "visible"))
    params = AttentionParams()
    features, on, scene, group, visible = [], [], [], [], []
    for record in records_of():
        category = record.category()
        if category not in ("visible", "no_impurity", "invisible"):
            continue
        index = len(visible)
        visible.append(category == "visible")
        objects = record.height > params.density.occupied_height
        saliency, conspicuity = scene_maps(record.color, objects, params)
        regions = salient_regions(saliency, objects, params)
        for region, row in candidate_features(record.color, record.height, objects, conspicuity, regions):
            if row is None:
                continue
            features.append(np.concatenate([row, chroma_features(record.color, objects, region.mask)]))
            on.append(category == "visible" and bool(np.any(region.mask & record.visible_target_cells)))
            scene.append(index)
            group.append(record.palette or "blocks")
    result = (np.array(features), np.array(on, bool), np.array(scene), np.array(group),
              np.array(visible, bool))
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(path, **dict(zip(("features", "on", "scene", "group", "visible"), result, strict=True)))
    return result


def main() -> None:
    import fresh_tuning_palettes
    command, rest = sys.argv[1], sys.argv[2:]
    data = nonlinear.shipped_rows_of(rows)
    assert TOP_REGIONS == 3
    for label, columns in (("12 features", slice(0, 12)), ("14 features (+ chroma)", slice(0, 14))):
        cut = (data[0][:, columns],) + data[1:]
        print(f"== {label}")
        if command == "cv":
            nonlinear.cv(cut)
        else:
            sets = {}
            for first in [int(a) for a in rest]:
                fresh = rows(f"fresh{first}", lambda f=first: fresh_tuning_palettes.fresh_records(f, 60))
                sets[first] = (fresh[0][:, columns],) + fresh[1:]
            nonlinear.fresh(cut, sets)


if __name__ == "__main__":
    main()
