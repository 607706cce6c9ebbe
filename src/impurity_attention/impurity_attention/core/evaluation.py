"""Judging the attention module against simulator ground truth.

A SceneRecord holds what the camera saw, projected to heightmaps, plus the ground truth carried into
heightmap coordinates: the segmentation image goes through the same projection as the colour (so
`labels` tells which body every heightmap cell shows), and target positions from the simulator's
poses give the cells of targets that no camera pixel sees.

Verdicts, per scene category:
- visible: some target shows at least MIN_VISIBLE_CELLS cells; success = mode TARGET and the target
  mask (m_t grown to its object) overlaps a target's cells; the detail says which share of the mask
  lies on targets (its precision).
- no_impurity: no target in the scene; a false alarm = mode TARGET.
- invisible: no target cell visible; success = mode OCCLUDED_REGION and the chosen cluster contains a
  hidden target's centre cell (a TARGET that lands on a target also finds it, counted apart).

colour_separable tells, for a visible scene, whether its impurity can be told from the product by colour
at all (an oracle built from the scene's truth): what a palette's detection rate should be read against.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import numpy as np

from impurity_common.colour import off_colours  # noqa: F401 (also re-exported)
from impurity_common.grid import HeightmapGrid

from .attention import AttentionMode, AttentionOutput
from .heightmap import rgbd_to_heightmaps

MIN_VISIBLE_CELLS = 20  # 80 mm^2: a target showing less than this is "hidden"
CATEGORIES = ("visible", "no_impurity", "invisible")
MODE_NAMES = ("TARGET", "OCCLUDED_REGION", "NONE")
# colour_separable: a colour is off the product by impurity_common.colour.off_colours (a smoothed
# histogram of the product's colours, below its own 1 % least likely cells: a detector allowed one product
# cell in a hundred as a false alarm); the impurity is separable when at least SEPARABLE_MIN_CELLS of its
# visible cells are (attention's least region, AttentionParams.min_region_area, 30 px = 1.2 cm^2).
SEPARABLE_MIN_CELLS = 30


def exposed_color(color: np.ndarray, exposure: float) -> np.ndarray:
    """(H, W, 3) uint8 with its RGB scaled by `exposure`, rounded and clipped at 255 (a saturating camera)."""
    return np.clip(np.asarray(color).astype(np.float32) * np.float32(exposure) + 0.5, 0, 255).astype(np.uint8)


@dataclass
class SceneRecord:
    scenario: str
    seed: int
    num_targets: int
    num_objects: int
    color: np.ndarray  # (rows, cols, 3) uint8 heightmap
    height: np.ndarray  # (rows, cols) float32
    labels: np.ndarray  # (rows, cols) int32 body id per cell, -1 unseen
    target_ids: tuple
    target_cells: tuple  # (row, col) of every target's centre (from ground-truth poses)
    palette: str = ""  # the simulator's appearance ("" = default)

    def exposed(self, exposure: float) -> SceneRecord:
        """The same scene with its colour map scaled by `exposure` (clipped at 255, as a saturating
        camera): exposure commutes with the heightmap projection, which only picks camera pixels."""
        color = exposed_color(self.color, exposure)
        return SceneRecord(self.scenario, self.seed, self.num_targets, self.num_objects, color, self.height,
                           self.labels, self.target_ids, self.target_cells, f"{self.palette}@x{exposure:g}")

    @property
    def visible_target_cells(self) -> np.ndarray:
        if not self.target_ids:
            return np.zeros_like(self.labels, bool)
        return np.isin(self.labels, list(self.target_ids))

    def category(self) -> str | None:
        """What the scene tests: "no_impurity" without targets, "invisible" for the invisible
        scenario, "visible" for random/challenging scenes showing a target; None for a random or
        challenging scene whose targets all ended up hidden (it tests neither)."""
        if not self.target_ids:
            return "no_impurity"
        if self.scenario == "invisible":
            return "invisible"
        if np.count_nonzero(self.visible_target_cells) >= MIN_VISIBLE_CELLS:
            return "visible"
        return None


@dataclass
class Verdict:
    scenario: str
    seed: int
    category: str
    mode: str
    score: float
    success: bool
    detail: str
    mask_precision: float | None = None  # visible scenes in TARGET mode: share of the mask on targets

    def as_dict(self) -> dict:
        return asdict(self)


def judge(record: SceneRecord, output: AttentionOutput) -> Verdict:
    category = record.category() or "excluded"
    mode = output.mode
    if category == "excluded":
        success, detail = False, "targets hidden in a random/challenging scene: not judged"
    elif category == "visible":
        hit = 0
        if mode == AttentionMode.TARGET:
            hit = int(np.count_nonzero(output.target_mask & record.visible_target_cells))
        success, detail = hit > 0, f"{hit} mask cells on a target"
    elif category == "no_impurity":
        false_alarm = mode == AttentionMode.TARGET
        success, detail = not false_alarm, "false alarm" if false_alarm else "ok"
    else:
        inside = []
        if mode == AttentionMode.OCCLUDED_REGION:
            rows, cols = record.height.shape
            mask = output.cluster.mask
            inside = [bool(mask[r, c]) for r, c in record.target_cells if 0 <= r < rows and 0 <= c < cols]
        found_by_target = (mode == AttentionMode.TARGET
                           and np.any(output.target_mask & record.visible_target_cells))
        success = any(inside)
        detail = (f"cluster holds {sum(inside)}/{len(record.target_cells)} hidden targets"
                  if mode == AttentionMode.OCCLUDED_REGION else
                  ("TARGET on a barely visible target" if found_by_target else "no cluster on a target"))
    precision = None
    if category == "visible" and mode == AttentionMode.TARGET:
        precision = float(np.count_nonzero(output.target_mask & record.visible_target_cells)
                          / max(1, np.count_nonzero(output.target_mask)))
    return Verdict(record.scenario, record.seed, category, mode.name, float(output.score), bool(success),
                   detail, precision)


def colour_separable(record: SceneRecord, min_object_height: float = 0.01) -> bool | None:
    """Whether a visible scene's impurity can be told from the product by colour alone, with the truth's
    help: a one-class model of the product's colours from the scene's own labelled product cells (object
    cells, height > min_object_height m, that are not a target's), judged on the visible target cells
    (SEPARABLE_* above). An oracle - it sees which cells are product - and a per-cell one: it reads no
    shape, so an impurity whose colours all occur on the product (a darker impurity of the product's hue
    beside the product's shaded faces; a light product and a lighter impurity both at the camera's
    ceiling) is not separable, whatever a detector does. None for scenes not in the "visible" category."""
    if record.category() != "visible":
        return None
    objects = record.height > min_object_height
    product = objects & ~np.isin(record.labels, list(record.target_ids))
    target = objects & record.visible_target_cells
    if not product.any():
        return True  # nothing to be confused with
    return bool(np.count_nonzero(off_colours(record.color, product) & target) >= SEPARABLE_MIN_CELLS)


def summarize(verdicts) -> dict:
    """Per category: scenes, successes, rate (for no_impurity: the TARGET false-alarm rate too)."""
    summary = {}
    for category in CATEGORIES:
        chosen = [v for v in verdicts if v.category == category]
        if not chosen:
            continue
        successes = sum(v.success for v in chosen)
        entry = {"scenes": len(chosen), "successes": successes, "rate": successes / len(chosen),
                 "modes": {m: sum(v.mode == m for v in chosen) for m in MODE_NAMES}}
        precisions = [v.mask_precision for v in chosen if v.mask_precision is not None]
        if precisions:
            entry["mask_precision_mean"] = float(np.mean(precisions))
            entry["mask_precision_min"] = float(np.min(precisions))
        if category == "no_impurity":
            entry["target_rate"] = entry["modes"]["TARGET"] / len(chosen)
        summary[category] = entry
    return summary


def record_from_world(world, scenario: str, seed: int, num_targets: int, num_objects: int,
                      grid: HeightmapGrid = HeightmapGrid(), keep_frame: bool = False, palette: str = ""):
    """Reset the simulator's scene (a ur5_driver_sim CellWorld, duck-typed: no import here), render it
    and project colour, depth and segmentation onto the heightmap grid. Returns a SceneRecord (and
    the camera frame when keep_frame)."""
    world.reset_scene(scenario, seed=seed, num_targets=num_targets, num_objects=num_objects, palette=palette)
    frame = world.render()
    truth = world.ground_truth(frame)
    maps = rgbd_to_heightmaps(frame.color, frame.depth, frame.intrinsics, frame.camera_pose, grid,
                              labels=frame.segmentation)
    target_cells = tuple(grid.base_to_pixel(*truth.poses[body][0][:2]) for body in truth.target_ids
                         if body in truth.poses)
    record = SceneRecord(scenario, int(seed), int(num_targets), int(num_objects), maps.color, maps.height,
                         maps.labels, tuple(int(b) for b in truth.target_ids), target_cells, palette)
    return (record, frame) if keep_frame else record


def save_records(path, records) -> None:
    """All records in one compressed .npz (a cache: rendering is the slow part of a calibration)."""
    arrays = {}
    for i, r in enumerate(records):
        arrays[f"{i}_color"], arrays[f"{i}_height"], arrays[f"{i}_labels"] = r.color, r.height, r.labels
        arrays[f"{i}_meta"] = np.array(json.dumps({
            "scenario": r.scenario, "seed": r.seed, "num_targets": r.num_targets,
            "num_objects": r.num_objects, "target_ids": list(r.target_ids),
            "target_cells": [list(c) for c in r.target_cells], "palette": r.palette}))
    np.savez_compressed(path, count=np.array(len(records)), **arrays)


def load_records(path) -> list:
    with np.load(path) as data:
        records = []
        for i in range(int(data["count"])):
            meta = json.loads(str(data[f"{i}_meta"]))
            records.append(SceneRecord(
                meta["scenario"], meta["seed"], meta["num_targets"], meta["num_objects"], data[f"{i}_color"],
                data[f"{i}_height"], data[f"{i}_labels"], tuple(meta["target_ids"]),
                tuple(tuple(c) for c in meta["target_cells"]), meta.get("palette", "")))
    return records
