"""Fourteenth session, tuning palettes only: does a scale-matched colour contrast of a candidate region add
what the verifier's twelve features miss? colour_contrast compares a region's mean colour with the colours of
the other object *pixels*, whose spread holds the product's shading and edges: a spread that wide can hide
an impurity close to the product's colour (on held-out palettes within 20 dE of the product the shipped cell
finds ~82 %). A region's mean is an average over its area, so here it is compared with the means of product
patches of about that area instead.

Per candidate region m (verifier.region_features' P: the object cells minus m grown by PRODUCT_MARGIN px;
cells with a channel at SATURATION or above are not read):
- patches: square windows of side round(sqrt(|m|)) (at least MIN_SIDE px) on a grid of stride side // 2,
  kept when at least MIN_FILL of the window's cells are usable product cells; a window's mean colour is the
  mean RGB over those cells. With fewer than MIN_WINDOWS kept windows the side shrinks (x SHRINK) down to
  MIN_SIDE; still fewer, or fewer than MIN_OWN usable cells in m: both features 0 (as chroma_features);
- patch_rgb: log(1 + d), d the Mahalanobis distance (capped at COLOUR_CAP) of m's mean RGB from the patch
  means, robust covariance: from the coordinate-wise median, C_STEPS concentration steps each keeping the
  C_KEEP share of the windows nearest (the C-step of minimum covariance determinant, one start), plus
  RGB_FLOOR^2 on the diagonal;
- patch_lc: log(1 + |z|) (|z| capped at COLOUR_CAP), z per axis of (log I, RG / I, BY / I) of the mean
  colours (saliency.opponent_colour, I floored at CHROMA_MIN_INTENSITY): (m's value - the patch means'
  median) / max(1.4826 x their median absolute deviation, LC_FLOOR): lighting-invariant chromaticity plus
  a log intensity, each in the spread of the product's patch means.

Compared, as docs/experiments_s13/chroma_features.py, by docs/experiments_s13/nonlinear.py's palette-grouped
nested CV on the shipped fit's rows (cv) and fitted on all of them, scored on the fresh tuning palette sets
random-500+ and random-600+ (fresh): 12 features, 12 + patch_rgb, 12 + patch_lc, 12 + both. Then the same
for the logistic model (the shipped form) and the trees on the random palettes whose impurity is within
CLOSE dE of the product (by_delta_e.closeness), where the misses are.

    python docs/experiments_s14/patch_contrast.py cv
    python docs/experiments_s14/patch_contrast.py fresh 500 600 [--caps=0.01,0.02]

Rows cached in runs/s14/patch_<name>.npz (with each scene's palette); their first twelve columns are checked
against nonlinear.py's rows in runs/s13/rows_<name>.npz when those exist. Every record's palette must be of
the tuning group (or the default palette): the script refuses any other.
"""
import math
import pathlib
import sys
import time

import cv2
import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
sys.path.insert(0, "docs/experiments_s13")
import by_delta_e  # noqa: E402
import calibrate_attention as ca  # noqa: E402
import nonlinear  # noqa: E402

from impurity_attention.core.attention import AttentionParams, salient_regions, scene_maps  # noqa: E402
from impurity_attention.core.saliency import CHROMA_MIN_INTENSITY, opponent_colour  # noqa: E402
from impurity_attention.core.verifier import (  # noqa: E402
    COLOUR_CAP,
    PRODUCT_MARGIN,
    SATURATION,
    TOP_REGIONS,
    candidate_features,
)
from impurity_learning.splits import palette_group  # noqa: E402

CACHE = pathlib.Path("runs/s14")
NEW = ("patch_rgb", "patch_lc")
MIN_SIDE = 3  # px, the least window side
MIN_FILL = 0.5  # a window is kept when this share of its cells are usable product cells
MIN_WINDOWS = 8  # fewer kept windows: the side shrinks
SHRINK = 0.7
MIN_OWN = 5  # usable cells of the region needed
C_STEPS, C_KEEP = 3, 0.75
RGB_FLOOR = 2.0  # RGB, added spread of the patch means (half the verifier's MIN_SPREAD: means spread less)
LC_FLOOR = np.array([0.02, 0.005, 0.005])  # log I, RG / I, BY / I
CLOSE = 20.0  # dE: "close" random palettes (by_delta_e)
CONFIGS = (("12 features", [*range(12)]), ("13 features (+ patch_rgb)", [*range(12), 12]),
           ("13 features (+ patch_lc)", [*range(12), 13]), ("14 features (+ both)", [*range(14)]))
KEYS = ("features", "on", "scene", "group", "visible")


def patch_means(color: np.ndarray, cells: np.ndarray, side: int) -> np.ndarray:
    """(N, 3) mean RGB over `cells` of the side x side windows (stride side // 2) holding >= MIN_FILL of
    them."""
    total = cv2.integral(np.where(cells[..., None], color, 0).astype(np.float64))
    count = cv2.integral(cells.astype(np.uint8))
    height, width = cells.shape
    stride = max(1, side // 2)
    y, x = np.meshgrid(np.arange(0, height - side + 1, stride), np.arange(0, width - side + 1, stride),
                       indexing="ij")
    y, x = y.ravel(), x.ravel()

    def box(table):
        return table[y + side, x + side] - table[y, x + side] - table[y + side, x] + table[y, x]

    number, sums = box(count), box(total)
    keep = number >= MIN_FILL * side * side
    return sums[keep] / number[keep][:, None]


def robust_distance(point: np.ndarray, points: np.ndarray) -> float:
    """Mahalanobis distance of `point` from `points` (N, 3) under a C-step robust covariance (docstring)."""
    centre = np.median(points, axis=0)
    covariance = np.cov(points, rowvar=False) + 1e-9 * np.eye(3)
    keep = max(4, math.ceil(C_KEEP * len(points)))
    for _ in range(C_STEPS):
        offsets = points - centre
        squared = np.einsum("ij,jk,ik->i", offsets, np.linalg.pinv(covariance), offsets)
        chosen = points[np.argsort(squared)[:keep]]
        centre, covariance = chosen.mean(axis=0), np.cov(chosen, rowvar=False) + 1e-9 * np.eye(3)
    covariance = covariance + RGB_FLOOR ** 2 * np.eye(3)
    offset = point - centre
    return float(np.sqrt(offset @ np.linalg.solve(covariance, offset)))


def log_chroma(rgb: np.ndarray) -> np.ndarray:
    """(N, 3) RGB (0-255, float) -> (N, 3) log I, RG / I, BY / I."""
    planes = opponent_colour(np.asarray(rgb, np.float32)[None])[0].astype(np.float64)  # I, RG, BY in 0-1
    intensity = np.maximum(planes[:, 0], CHROMA_MIN_INTENSITY)
    return np.stack([np.log(intensity), planes[:, 1] / intensity, planes[:, 2] / intensity], axis=-1)


def patch_features(color: np.ndarray, objects: np.ndarray, region: np.ndarray) -> np.ndarray:
    """(patch_rgb, patch_lc) of `region` (module docstring)."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * PRODUCT_MARGIN + 1,) * 2)
    product = objects & ~(cv2.dilate(region.astype(np.uint8), kernel) > 0)
    if not product.any():
        product = objects & ~region
    usable = np.all(color < SATURATION, axis=-1)
    own = color[region & usable].astype(np.float64)
    if len(own) < MIN_OWN:
        return np.zeros(2)
    side = max(MIN_SIDE, round(math.sqrt(float(region.sum()))))
    while True:
        means = patch_means(color, product & usable, side)
        if len(means) >= MIN_WINDOWS or side == MIN_SIDE:
            break
        side = max(MIN_SIDE, int(side * SHRINK))
    if len(means) < MIN_WINDOWS:
        return np.zeros(2)
    mine = own.mean(axis=0)
    rgb = min(robust_distance(mine, means), COLOUR_CAP)
    reference, point = log_chroma(means), log_chroma(mine[None])[0]
    centre = np.median(reference, axis=0)
    spread = np.maximum(1.4826 * np.median(np.abs(reference - centre), axis=0), LC_FLOOR)
    lc = min(float(np.linalg.norm((point - centre) / spread)), COLOUR_CAP)
    return np.array([math.log1p(rgb), math.log1p(lc)])


def rows(name: str, records_of) -> tuple:
    """nonlinear.rows' rows with the NEW columns appended; also caches each scene's palette."""
    path = CACHE / f"patch_{name}.npz"
    if not path.exists():
        from tqdm import tqdm
        params = AttentionParams()
        features, on, scene, group, visible, palettes = [], [], [], [], [], []
        records = records_of()
        groups = {palette_group(r.palette) for r in records}
        if not groups <= {"tuning", "default"}:
            raise SystemExit(f"refusing {name}: palette groups {sorted(groups)} (tuning palettes only)")
        for record in tqdm(records, desc=f"rows {name}", unit="scene"):
            category = record.category()
            if category not in ("visible", "no_impurity", "invisible"):
                continue
            index = len(visible)
            visible.append(category == "visible")
            palettes.append(record.palette or "blocks")
            objects = record.height > params.density.occupied_height
            saliency, conspicuity = scene_maps(record.color, objects, params)
            regions = salient_regions(saliency, objects, params)
            for region, row in candidate_features(record.color, record.height, objects, conspicuity, regions):
                if row is None:
                    continue
                features.append(np.concatenate([row, patch_features(record.color, objects, region.mask)]))
                on.append(category == "visible" and bool(np.any(region.mask & record.visible_target_cells)))
                scene.append(index)
                group.append(record.palette or "blocks")
        result = (np.array(features), np.array(on, bool), np.array(scene), np.array(group),
                  np.array(visible, bool))
        CACHE.mkdir(parents=True, exist_ok=True)
        np.savez(path, palettes=np.array(palettes), **dict(zip(KEYS, result, strict=True)))
        reference = nonlinear.CACHE / f"rows_{name}.npz"
        if reference.exists():
            old = np.load(reference)
            same = old["features"].shape == (len(result[0]), 12) and bool(np.all(old["on"] == result[1]))
            gap = float(np.max(np.abs(old["features"] - result[0][:, :12]))) if same else float("nan")
            print(f"  {name}: twelve columns against {reference}: same rows {same}, max |diff| {gap:.2e}",
                  file=sys.stderr)
    data = np.load(path)
    return tuple(data[k] for k in KEYS)


def scene_palettes(name: str) -> np.ndarray:
    return np.load(CACHE / f"patch_{name}.npz")["palettes"]


def close_scenes(palettes: np.ndarray) -> np.ndarray:
    """Per scene: its palette is a random one whose impurity is within CLOSE dE of the product."""
    closeness = {p: by_delta_e.closeness(p) for p in set(palettes) if p.startswith("random-")}
    return np.array([p in closeness and closeness[p] < CLOSE for p in palettes])


def rate(decided, hit, visible, chosen) -> str:
    found = int(np.sum(decided & hit & visible & chosen))
    shown = int(np.sum(visible & chosen))
    false, clean = int(np.sum(decided & ~visible & chosen)), int(np.sum(~visible & chosen))
    return (f"found {found}/{shown} ({100 * found / max(shown, 1):.1f} %), false TARGET {false}/{clean} "
            f"({100 * false / max(clean, 1):.1f} %)")


def cv_close(data, close, make) -> str:
    """nonlinear.cv's nested CV decisions per scene (same folds, same threshold), read on `close` scenes."""
    from sklearn.model_selection import GroupKFold
    features, on, scene, group, visible = data
    count = len(visible)
    decided, hit_all = np.zeros(count, bool), np.zeros(count, bool)
    for train, test in GroupKFold(n_splits=ca.VERIFIER_FOLDS).split(features, on, group):
        model = make().fit(features[train], on[train])
        own_best, _ = ca.scene_decisions(model.predict_proba(features[train])[:, 1], on[train], scene[train],
                                         count)
        seen = np.zeros(count, bool)
        seen[scene[train]] = True
        least = ca.threshold_at(own_best[seen], visible[seen], nonlinear.CAP)
        best, hit = ca.scene_decisions(model.predict_proba(features[test])[:, 1], on[test], scene[test],
                                       count)
        unseen = np.zeros(count, bool)
        unseen[scene[test]] = True
        decided |= (best >= least) & unseen
        hit_all[unseen] = hit[unseen]
    return rate(decided, hit_all, visible, close)


def main() -> None:
    import fresh_tuning_palettes
    started = time.perf_counter()
    command, rest = sys.argv[1], sys.argv[2:]
    assert TOP_REGIONS == 3
    data = nonlinear.shipped_rows_of(rows)
    palettes = scene_palettes("shipped")
    close = close_scenes(palettes)
    caps = [float(c) for a in rest if a.startswith("--caps=") for c in a[len("--caps="):].split(",")]
    caps = caps or [nonlinear.CAP]
    sets = {}
    if command == "fresh":
        for first in [int(a) for a in rest if a.isdigit()]:
            sets[first] = rows(f"fresh{first}", lambda f=first: fresh_tuning_palettes.fresh_records(f, 60))
    chosen = {"logistic": nonlinear.models()["logistic"], "trees": nonlinear.models()["trees"]}
    for label, columns in CONFIGS:
        cut = (data[0][:, columns],) + data[1:]
        print(f"== {label}")
        if command == "cv":
            nonlinear.cv(cut)
            print(f"  -- random palettes within {CLOSE:.0f} dE of the product ({len(set(palettes[close]))} "
                  f"palettes, {int(np.sum(close & cut[4]))} visible scenes):")
            for name, make in chosen.items():
                print(f"  {name:10s} nested CV: {cv_close(cut, close, make)}")
        else:
            fresh_cut = {first: (f[0][:, columns],) + f[1:] for first, f in sets.items()}
            nonlinear.fresh(cut, fresh_cut, caps)
            print(f"  -- random palettes within {CLOSE:.0f} dE of the product:")
            for name, make in chosen.items():
                features, on, scene, _, visible = cut
                model = make().fit(features, on)
                best, _ = ca.scene_decisions(model.predict_proba(features)[:, 1], on, scene, len(visible))
                for cap in caps:
                    least = ca.threshold_at(best, visible, cap)
                    line = f"  {name:10s} cap {100 * cap:.0f} %:"
                    for first, (f, o, s, _, v) in fresh_cut.items():
                        p_best, p_hit = ca.scene_decisions(model.predict_proba(f)[:, 1], o, s, len(v))
                        near = close_scenes(scene_palettes(f"fresh{first}"))
                        line += f"  random-{first}+ {rate(p_best >= least, p_hit, v, near)}"
                    print(line)
        sys.stdout.flush()
    print(f"# {time.perf_counter() - started:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
