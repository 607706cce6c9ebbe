"""Thirty-third session, tuning data only, a screening (nothing is adopted on it): do the verifier's
comparison features find more near-product impurities when the product they compare a region with leaves
out the view's other salient regions?

Every visible scene of the perception sets holds two impurities (the 260 fresh tuning palettes of
docs/experiments_s32/threshold_curve.py: 2600 visible scenes, num_targets 2). The verifier compares a region
with "the product", P = the object cells outside the region grown by PRODUCT_MARGIN: the other impurity is in
P. Its colour then counts as a product colour: off_colour_share, colour_contrast and the orientation fit all
see the impurity's colour "on the product". The colour oracle (evaluation.colour_separable, 97.4 % on the
fourteenth set against the verifier's 94.35 %) leaves every impurity out of the product. This reads the
eleven region features a second time, "excluded": against the object cells outside every other salient
region of the view (grown by PRODUCT_MARGIN), and compares by palette-grouped cross-validation (5 folds, each
fold's palettes unseen by its model; the threshold from the training folds at 1 % false TARGET, as
calibrate_attention.verifier_fit's nested figures):
- A: the shipped fifteen features;
- B: the fifteen and the eleven excluded ones;
- C: the eleven excluded ones and the four context features (the excluded features in place of the shipped).
Then each, fitted on all 260 palettes, on the default palette's exposure set (tuning seeds 30000+, x0.5 / x1
/ x2): false TARGET and found.

    python docs/experiments_s33/excluded_screen.py [--jobs 2]
Rows are cached in runs/s33/excluded_rows.npz.
"""
import argparse
import multiprocessing
import pathlib
import sys
from typing import NamedTuple

import cv2
import numpy as np

sys.path[:0] = ["scripts", "docs/experiments_s11", "docs/experiments_s12", "docs/experiments_s13"]
import calibrate_attention as ca  # noqa: E402
import exposure_wide  # noqa: E402
import fresh_layouts  # noqa: E402
import more_palettes  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, salient_regions, sanitize, scene_maps  # noqa: E402
from impurity_attention.core.verifier import (  # noqa: E402
    CONTEXT_FEATURES,
    FEATURES,
    PRODUCT_MARGIN,
    REGION_FEATURES,
    TOP_REGIONS,
    ViewPlanes,
    candidate_features,
    region_features,
)

CACHE = pathlib.Path("runs/s33/excluded_rows.npz")
EXCLUDED = tuple(f"{name}_excluded" for name in REGION_FEATURES)
ALL = FEATURES + EXCLUDED
MODELS = {"A shipped fifteen": FEATURES, "B fifteen + excluded": FEATURES + EXCLUDED,
          "C excluded + context": EXCLUDED + CONTEXT_FEATURES}
PARAMS = AttentionParams()
RECORDS: list = []


class ScoredView(NamedTuple):
    """A view as attend scores it: sanitized color and height, object cells, VOCUS2's conspicuity, the salient
    regions, and [(rank, region, verifier features, on a visible target)] for its scored regions that have
    features."""
    color: np.ndarray
    height: np.ndarray
    objects: np.ndarray
    conspicuity: dict
    regions: list
    candidates: list


def scored_view(record) -> ScoredView:
    """The view of a scene record as attend() scores it (the rows every screening here starts from)."""
    color, height = sanitize(record.color, record.height)
    objects = height > PARAMS.density.occupied_height
    saliency, conspicuity = scene_maps(color, objects, PARAMS)
    regions = salient_regions(saliency, objects, PARAMS)
    candidates = [(rank, region, row,
                   record.category() == "visible" and bool(np.any(region.mask & record.visible_target_cells)))
                  for rank, (region, row) in enumerate(candidate_features(color, height, objects, conspicuity,
                                                                          regions))
                  if row is not None]
    assert len(candidates) <= TOP_REGIONS
    return ScoredView(color, height, objects, conspicuity, regions, candidates)


def rows_of(index: int) -> list:
    """[(features (len(ALL),), on target)] of RECORDS[index]'s scored regions (as attend scores them)."""
    view = scored_view(RECORDS[index])
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * PRODUCT_MARGIN + 1,) * 2)
    grown = [cv2.dilate(r.mask.astype(np.uint8), kernel) > 0 for r in view.regions]
    planes = ViewPlanes.of(view.color, view.height)
    out = []
    for rank, region, row, on in view.candidates:
        others = np.zeros_like(view.objects)
        for k, mask in enumerate(grown):
            if k != rank:
                others |= mask
        kept = view.objects & ~(others & ~region.mask)
        excluded = region_features(view.color, view.height, kept, view.conspicuity, region.mask, True, planes)
        if excluded is None:  # nothing left beside the region: the shipped features stand in
            excluded = row[:len(REGION_FEATURES)]
        out.append((np.concatenate([row, excluded]), on))
    return out


def table(records: list, jobs: int, rows=rows_of) -> tuple:
    """(features, on, scene, group, visible) over records in the three judged categories; rows(index) gives
    RECORDS[index]'s [(features, on target)] (forked workers read RECORDS)."""
    global RECORDS
    RECORDS = [r for r in records if r.category() in evaluation.CATEGORIES]
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        per_scene = pool.map(rows, range(len(RECORDS)), chunksize=8)
    feats, on, scene, group = [], [], [], []
    for index, rows in enumerate(per_scene):
        for row, hit in rows:
            feats.append(row)
            on.append(hit)
            scene.append(index)
            group.append(RECORDS[index].palette or "blocks")
    visible = np.array([r.category() == "visible" for r in RECORDS])
    return np.array(feats), np.array(on, bool), np.array(scene), np.array(group), visible


def fit(rows, labels):
    from sklearn.linear_model import LogisticRegression
    from sklearn.preprocessing import StandardScaler
    scaler = StandardScaler().fit(rows)
    model = LogisticRegression(C=1.0, max_iter=5000).fit(np.nan_to_num(scaler.transform(rows)), labels)
    return scaler, model, np.nanmin(rows, axis=0), np.nanmax(rows, axis=0)


def predict(fitted, rows):
    scaler, model, low, high = fitted
    return model.predict_proba(np.nan_to_num(scaler.transform(np.clip(rows, low, high))))[:, 1]


PARTS = ("features", "on", "scene", "group", "visible")


def exposed_tables(default: list, jobs: int, rows=rows_of) -> dict:
    """{exposure: table()} of the default palette's scene records at each of calibrate_attention's
    EXPOSURES."""
    return {e: table([r if e == 1.0 else r.exposed(e) for r in default], jobs, rows) for e in ca.EXPOSURES}


def run(cache: pathlib.Path, rows, names: tuple, models: dict, jobs: int) -> None:
    """The screening: table()'s rows (by `rows`) of the 260 fresh tuning palettes and of the default palette's
    exposure set, cached in `cache`, then compare() over `names` (the rows' columns) and `models`."""
    if cache.exists():
        data = np.load(cache)
        palettes = tuple(data[k] for k in PARTS)
        exposed = {e: tuple(data[f"x{e:g}_{k}"] for k in PARTS) for e in ca.EXPOSURES}
    else:
        records = more_palettes.extra_records(200) + fresh_layouts.own_layout_records(700, 60)
        palettes = table(records, jobs, rows)
        default = exposure_wide.collect()
        exposed = exposed_tables(default, jobs, rows)
        arrays = dict(zip(PARTS, palettes, strict=True))
        for e, parts in exposed.items():
            arrays.update({f"x{e:g}_{k}": v for k, v in zip(PARTS, parts, strict=True)})
        cache.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(cache, **arrays)
    compare(palettes, exposed, names, models)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--jobs", type=int, default=2)
    run(CACHE, rows_of, ALL, MODELS, parser.parse_args().jobs)


def compare(palettes: tuple, exposed: dict, names: tuple = ALL, models: dict = MODELS) -> None:
    """`models` ({name: feature names}, columns of `names`) by palette-grouped cross-validation on `palettes`
    (table()'s five arrays), then each fitted on all of them and read on `exposed` ({exposure: table()'s
    arrays} of the default palette's scenes)."""
    from sklearn.model_selection import GroupKFold
    features, on, scene, group, visible = palettes
    count = len(visible)
    print(f"{count} scenes ({int(visible.sum())} visible), {len(features)} regions, "
          f"{len(set(group))} palettes")
    for name, chosen in models.items():
        columns = [names.index(c) for c in chosen]
        x = features[:, columns]
        found = seen_visible = false = seen_clean = 0
        for train, test in GroupKFold(n_splits=5).split(x, on, group):
            fitted = fit(x[train], on[train])
            own_best, _ = ca.scene_decisions(predict(fitted, x[train]), on[train], scene[train], count)
            seen = np.zeros(count, bool)
            seen[scene[train]] = True
            least = ca.threshold_at(own_best[seen], visible[seen], 0.01)
            best, hit = ca.scene_decisions(predict(fitted, x[test]), on[test], scene[test], count)
            unseen = np.zeros(count, bool)
            unseen[scene[test]] = True
            decided = (best >= least) & unseen
            found += int(np.sum(decided & hit & visible))
            seen_visible += int(np.sum(unseen & visible))
            false += int(np.sum(decided & ~visible))
            seen_clean += int(np.sum(unseen & ~visible))
        fitted = fit(x, on)
        best, _ = ca.scene_decisions(predict(fitted, x), on, scene, count)
        least = ca.threshold_at(best, visible, 0.01)
        line = [f"{name:22s} cross-validated found {found}/{seen_visible} "
                f"({100 * found / seen_visible:.2f} %), "
                f"false TARGET {false}/{seen_clean} ({100 * false / seen_clean:.2f} %)"]
        for e, (ef, eon, escene, _, evisible) in exposed.items():
            ebest, ehit = ca.scene_decisions(predict(fitted, ef[:, columns]), eon, escene, len(evisible))
            taken = ebest >= least
            line.append(f"x{e:g} false {int(np.sum(taken & ~evisible))}/{int(np.sum(~evisible))} found "
                        f"{int(np.sum(taken & ehit & evisible))}/{int(evisible.sum())}")
        print(f"{line[0]}\n    default palette, fitted on all (threshold {least:.3f}): "
              + "; ".join(line[1:]),
              flush=True)


if __name__ == "__main__":
    main()
