"""Fits for the attention module on tuning scene records: the impurity network and the region verifier with
the thresholds attention reads from its probability (RegionVerifier threshold, last_look, stall_look).

Shapes: a record's colour heightmap (H, W, 3) uint8 and height map (H, W) m; verifier rows (N, F) over the
feature names of impurity_attention.core.verifier (ALL_FEATURES with a network, else FEATURES).
"""

from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np

from impurity_attention.core import evaluation
from impurity_attention.core.attention import AttentionParams

NETWORK_FILE, VERIFIER_FILE = "impurity_net.pt", "verifier.json"  # the names of the shipped files
NETWORK_EPOCHS = 6
VERIFIER_FOLDS = 5  # palette-grouped cross-validation folds (needs at least as many palettes)
# Per RegionVerifier threshold field, the share of tuning scenes without a visible impurity it lets through
# as a TARGET: threshold 1 %; last_look and stall_look the shares the shipped values (0.391, 0.134) let
# through under the shipped verifier on its tuning scenes (127 and 333 of 2933).
CAPS = {"threshold": 0.01, "last_look": 127 / 2933, "stall_look": 333 / 2933}


def fit_network(records: list, epochs: int = NETWORK_EPOCHS, positive_weight: float | None = None,
                params: AttentionParams = AttentionParams(), progress: bool = True) -> tuple:
    """Train the impurity network (impurity_learning.impurity_net_training) on the records' visible
    impurity cells, exposure drawn in splits.TRAINING_EXPOSURE. Returns (network, mean loss per epoch,
    provenance). ValueError on no records."""
    import torch

    from impurity_attention.core.attention import sanitize

    from .. import splits
    from ..impurity_net_training import POSITIVE_WEIGHT, train_impurity_net

    records = [r for r in records if r.category() in evaluation.CATEGORIES]
    if not records:
        raise ValueError("no scene with a visible impurity, none or a heap to train the network on")
    torch.set_num_threads(max(1, min(4, torch.get_num_threads())))
    views = []
    for record in records:
        color, height = sanitize(record.color, record.height)
        views.append((color, height, height > params.density.occupied_height, record.visible_target_cells))
    weight = POSITIVE_WEIGHT if positive_weight is None else positive_weight
    net, losses = train_impurity_net(views, epochs, exposure=splits.TRAINING_EXPOSURE, positive_weight=weight,
                                     progress=progress)
    palettes = len({r.palette or splits.DEFAULT_PALETTE for r in records})
    provenance = (f"python -m impurity_learning.calibrate network: {len(views)} tuning views of {palettes} "
                  f"palettes, {epochs} epochs; mean loss {losses[0]:.4f} -> {losses[-1]:.4f}")
    return net, losses, provenance


def verifier_rows(records: list, params: AttentionParams = AttentionParams(), network=None,
                  progress: bool = True) -> tuple:
    """Per record of evaluation.CATEGORIES, its best salient regions' features as attention scores them
    (verifier.candidate_features; network: the impurity network NETWORK_FEATURES read, else they are NaN).
    Returns (features (N, len(ALL_FEATURES)), on an impurity (N,) bool, scene index (N,), palette (N,),
    visible per scene (S,) bool); a scene without a scored region has no row."""
    from tqdm import tqdm

    from impurity_attention.core.attention import salient_regions, scene_maps
    from impurity_attention.core.verifier import candidate_features

    rows, on, scene, group, visible = [], [], [], [], []
    for record in tqdm(records, desc="verifier features", unit="scene", disable=not progress):
        category = record.category()
        if category not in evaluation.CATEGORIES:
            continue
        index = len(visible)
        visible.append(category == "visible")
        objects = record.height > params.density.occupied_height
        saliency, conspicuity = scene_maps(record.color, objects, params)
        regions = salient_regions(saliency, objects, params)
        for region, row in candidate_features(record.color, record.height, objects, conspicuity, regions,
                                              network=network):
            if row is None:  # every object in view: attention lets saliency decide
                continue
            rows.append(row)
            on.append(category == "visible" and bool(np.any(region.mask & record.visible_target_cells)))
            scene.append(index)
            group.append(record.palette or "blocks")
    return (np.array(rows, dtype=float), np.array(on, bool), np.array(scene, int), np.array(group),
            np.array(visible, bool))


def scene_decisions(probability, on, scene, count: int) -> tuple:
    """Per scene (count scenes): the highest region probability (-1 without a region) and whether that
    region lies on the impurity: what attention's verifier decision reads."""
    best = np.full(count, -1.0)
    hit = np.zeros(count, bool)
    for p, o, s in zip(probability, on, scene, strict=True):
        if p > best[s]:
            best[s], hit[s] = p, o
    return best, hit


def threshold_at(best, visible, cap: float) -> float:
    """The least threshold (just above a clean scene's best probability) that lets at most floor(cap x the
    scenes without a visible impurity) of them through (0.0 when that is all of them)."""
    best, visible = np.asarray(best, float), np.asarray(visible, bool)
    allowed = int(np.floor(cap * np.sum(~visible)))
    clean = np.sort(best[~visible])[::-1]
    return float(np.nextafter(clean[allowed], 1.0)) if allowed < len(clean) else 0.0


def _fit(rows, labels):
    from sklearn.linear_model import LogisticRegression
    from sklearn.preprocessing import StandardScaler

    scaler = StandardScaler().fit(rows)  # an unknown value (NaN) is left out of the mean and spread
    standardised = np.nan_to_num(scaler.transform(rows), nan=0.0)  # an unknown value counts as the mean
    model = LogisticRegression(C=1.0, max_iter=5000).fit(standardised, labels)
    return scaler, model


def _predict(fitted, rows):
    scaler, model = fitted
    return model.predict_proba(np.nan_to_num(scaler.transform(rows), nan=0.0))[:, 1]


def fit_verifier(features, on, scene, group, visible, feature_names: tuple, caps: dict = CAPS,
                 provenance: str = "") -> tuple:
    """Logistic regression (scikit-learn, standardised features, C = 1) of "this region lies on the
    impurity" over verifier_rows' rows, restricted to `feature_names` (names of verifier.ALL_FEATURES); its
    threshold, last_look and stall_look chosen by choose_thresholds(caps) on the fitting scenes' best
    probabilities. Returns (RegionVerifier, figures): figures holds found / false_target at the threshold on
    the fitting scenes and, with at least VERIFIER_FOLDS palettes, the same out of fold over palette-grouped
    folds (what a palette unseen by the model gets), and "thresholds" (choose_thresholds' table). ValueError
    when the rows hold only one class."""
    from impurity_attention.core.verifier import ALL_FEATURES, RegionVerifier

    if len(set(on.tolist())) < 2:
        raise ValueError("the verifier needs regions on an impurity and regions off one: give more scenes")
    columns = features[:, [ALL_FEATURES.index(name) for name in feature_names]]
    count = len(visible)
    cap = caps["threshold"]

    def rates(probability) -> dict:
        best, hit = scene_decisions(probability, on, scene, count)
        taken = best >= threshold_at(best, visible, cap)
        return {"found": float(np.mean(taken[visible] & hit[visible])) if visible.any() else float("nan"),
                "false_target": float(np.mean(taken[~visible])) if (~visible).any() else float("nan")}

    figures = {"scenes": count, "regions": len(columns), "palettes": len(set(group.tolist()))}
    if figures["palettes"] >= VERIFIER_FOLDS:
        from sklearn.model_selection import GroupKFold

        out_of_fold = np.zeros(len(columns))
        for train, test in GroupKFold(n_splits=VERIFIER_FOLDS).split(columns, on, group):
            out_of_fold[test] = _predict(_fit(columns[train], on[train]), columns[test])
        figures["out_of_fold"] = rates(out_of_fold)
    fitted = _fit(columns, on)
    probability = _predict(fitted, columns)
    figures["fitted"] = rates(probability)
    best, _ = scene_decisions(probability, on, scene, count)
    figures["thresholds"] = choose_thresholds(best, visible, caps)
    scaler, model = fitted
    verifier = RegionVerifier(
        mean=tuple(round(float(v), 6) for v in scaler.mean_),
        scale=tuple(round(float(v), 6) for v in scaler.scale_),
        coef=tuple(round(float(v), 6) for v in model.coef_[0]),
        intercept=round(float(model.intercept_[0]), 6),
        **{field: entry["value"] for field, entry in figures["thresholds"].items()},
        low=tuple(round(float(v), 6) for v in np.nanmin(columns, axis=0)),
        high=tuple(round(float(v), 6) for v in np.nanmax(columns, axis=0)),
        provenance=provenance, features=tuple(feature_names))
    return verifier, figures


def _offset_fit(columns, offset, labels, c: float = 1.0) -> tuple:
    """(weights (F,), bias) of the logistic regression logit = offset + columns . weights + bias, L2 penalty
    on the weights as scikit-learn's (C = c): the model given by `offset` held, the added terms fitted."""
    from scipy.optimize import minimize

    def loss(theta):
        z = offset + columns @ theta[:-1] + theta[-1]
        p = 1.0 / (1.0 + np.exp(-z))
        value = c * np.sum(np.logaddexp(0.0, z) - labels * z) + 0.5 * theta[:-1] @ theta[:-1]
        gradient = c * np.append(columns.T @ (p - labels), np.sum(p - labels))
        gradient[:-1] += theta[:-1]
        return value, gradient

    theta = minimize(loss, np.zeros(columns.shape[1] + 1), jac=True, method="L-BFGS-B").x
    return theta[:-1], float(theta[-1])


def extend_verifier(model, features, on, scene, group, visible, added: tuple, caps: dict = CAPS,
                    provenance: str = "") -> tuple:
    """Refit only the terms of `added` (names of verifier.ALL_FEATURES) of the RegionVerifier `model`, on
    verifier_rows' rows, its other weights held: a feature the model reads has its weight moved, one it does
    not read is added (standardised over the rows, clipped to their range), and the intercept moves with
    them (_offset_fit, the model's own logit as the offset). Its threshold, last_look and stall_look are
    chosen anew by choose_thresholds(caps) on the rows' scenes. For a model fitted on more data than is at
    hand (the shipped one), taught a kind of impurity its data lacked. Returns (RegionVerifier, figures) as
    fit_verifier (out of fold: the added terms fitted without the palettes of a fold)."""
    from impurity_attention.core.verifier import ALL_FEATURES

    unknown = [name for name in added if name not in ALL_FEATURES]
    if unknown or not added:
        raise ValueError(f"features to refit must be names of ALL_FEATURES ({', '.join(ALL_FEATURES)}), "
                         f"got {list(added)}")
    if len(set(on.tolist())) < 2:
        raise ValueError("the verifier needs regions on an impurity and regions off one: give more scenes")
    new = [name for name in added if name not in model.features]
    raw = features[:, [ALL_FEATURES.index(name) for name in new]]
    mean, scale = np.nanmean(raw, axis=0), np.nanstd(raw, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    grown = dataclasses.replace(
        model, features=model.features + tuple(new),
        mean=model.mean + tuple(round(float(v), 6) for v in mean),
        scale=model.scale + tuple(round(float(v), 6) for v in scale), coef=model.coef + (0.0,) * len(new),
        low=model.low + tuple(round(float(v), 6) for v in np.nanmin(raw, axis=0)),
        high=model.high + tuple(round(float(v), 6) for v in np.nanmax(raw, axis=0)))
    positions = [grown.features.index(name) for name in added]
    read = features[:, [ALL_FEATURES.index(name) for name in grown.features]]
    standard = np.nan_to_num((np.clip(read, grown.low, grown.high) - np.asarray(grown.mean))
                             / np.asarray(grown.scale), nan=0.0)
    offset = standard @ np.asarray(grown.coef) + grown.intercept
    columns = standard[:, positions]
    count = len(visible)

    def probability_of(weights, bias, rows=slice(None)):
        return 1.0 / (1.0 + np.exp(-(offset[rows] + columns[rows] @ weights + bias)))

    def rates(probability) -> dict:
        best, hit = scene_decisions(probability, on, scene, count)
        taken = best >= threshold_at(best, visible, caps["threshold"])
        return {"found": float(np.mean(taken[visible] & hit[visible])) if visible.any() else float("nan"),
                "false_target": float(np.mean(taken[~visible])) if (~visible).any() else float("nan")}

    figures = {"scenes": count, "regions": len(columns), "palettes": len(set(group.tolist()))}
    figures["before"] = rates(probability_of(np.zeros(len(added)), 0.0))
    if figures["palettes"] >= VERIFIER_FOLDS:
        from sklearn.model_selection import GroupKFold

        out_of_fold = np.zeros(len(columns))
        for train, test in GroupKFold(n_splits=VERIFIER_FOLDS).split(columns, on, group):
            out_of_fold[test] = probability_of(*_offset_fit(columns[train], offset[train], on[train]), test)
        figures["out_of_fold"] = rates(out_of_fold)
    weights, bias = _offset_fit(columns, offset, on.astype(float))
    probability = probability_of(weights, bias)
    figures["fitted"] = rates(probability)
    best, _ = scene_decisions(probability, on, scene, count)
    figures["thresholds"] = choose_thresholds(best, visible, caps)
    coef = list(grown.coef)
    for position, weight in zip(positions, weights, strict=True):
        coef[position] = round(coef[position] + float(weight), 6)
    verifier = dataclasses.replace(
        grown, coef=tuple(coef), intercept=round(grown.intercept + bias, 6), provenance=provenance,
        **{field: entry["value"] for field, entry in figures["thresholds"].items()})
    return verifier, figures


def choose_thresholds(best, visible, caps: dict = CAPS) -> dict:
    """Per RegionVerifier threshold field of `caps` (threshold, last_look, stall_look): the least probability
    that lets at most that share of the scenes without a visible impurity through (threshold_at, rounded up
    to 6 digits, so the rounding lets no more through, and kept inside (0, 1) as RegionVerifier requires),
    and how many it lets through."""
    best, visible = np.asarray(best, float), np.asarray(visible, bool)
    chosen = {}
    for field, cap in caps.items():
        exact = threshold_at(best, visible, cap)
        threshold = math.ceil(exact * 1e6) / 1e6
        threshold = round(min(max(threshold + 1e-6 if threshold < exact else threshold, 1e-6), 1 - 1e-6), 6)
        chosen[field] = {"value": threshold, "cap": cap,
                         "clean_through": int(np.sum(best[~visible] >= threshold)),
                         "clean_scenes": int(np.sum(~visible))}
    return chosen


def attention_params(directory: pathlib.Path | None, network_path=None) -> AttentionParams:
    """AttentionParams with what a calibration directory holds: its impurity network (or `network_path`)
    and its verifier (verifier.read_verifier, with its thresholds); the shipped ones for whatever it does not
    hold."""
    from impurity_attention.core.impurity_net import read_network
    from impurity_attention.core.verifier import read_verifier

    params = AttentionParams()
    directory = pathlib.Path(directory) if directory is not None else None
    if network_path is None and directory is not None and (directory / NETWORK_FILE).exists():
        network_path = directory / NETWORK_FILE
    if network_path is not None:
        params = dataclasses.replace(params, impurity_net=read_network(network_path))
    if directory and (directory / VERIFIER_FILE).exists():
        params = dataclasses.replace(params, verifier=read_verifier(directory / VERIFIER_FILE))
    return params
