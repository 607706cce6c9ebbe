#!/usr/bin/env python3
"""Draw docs/images/attention_saliency.png and attention_dbscan.png: simulator scenes projected onto the
heightmap and answered by attention with the shipped defaults (impurity_attention.core.attention.attend).

attention_saliency.png: one row per scene (a random and a challenging scene with two impurities, a
random scene without any): camera image, colour heightmap, VOCUS2 saliency, attention's answer (mode and
score), the 112 px crop over its mask. attention_dbscan.png: an invisible scene (impurities under heaps):
camera image, height 0-10 cm, the DBSCAN clusters (grey: too low or small to hide anything; white outline:
the heap attended; red cross: a hidden impurity's centre from the simulator's ground truth), the answer,
the crop over its all-one mask. 224 px tiles; scenes from the tuning seed range (impurity_learning.splits),
so the same command draws the same pictures.

    python scripts/draw_attention.py [--output-dir docs/images]
"""

from __future__ import annotations

import argparse
import pathlib

import cv2
import numpy as np

from impurity_attention.core import evaluation
from impurity_attention.core.attention import AttentionParams, attend, debug_image
from impurity_attention.core.saliency import normalised

ROOT = pathlib.Path(__file__).resolve().parents[1]
NUM_OBJECTS = 20
TILE = 224
# (scenario, seed, impurities): tuning seeds
SALIENCY_SCENES = (("random", 1001, 2), ("challenging", 1102, 2), ("random", 1201, 0))
DBSCAN_SCENE = ("invisible", 1515, 2)


def tile(image: np.ndarray, label: str) -> np.ndarray:
    """(TILE, TILE, 3) uint8 RGB: `image` resized (nearest) with `label` written along its bottom."""
    if image.shape[:2] != (TILE, TILE):
        image = cv2.resize(image, (TILE, TILE), interpolation=cv2.INTER_NEAREST)
    image = np.ascontiguousarray(image)
    cv2.putText(image, label, (4, TILE - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
    return image


def camera_tile(color: np.ndarray) -> np.ndarray:
    """The camera image (480, 640, 3) cut to its central square at TILE px."""
    return cv2.resize(color, (298, TILE), interpolation=cv2.INTER_AREA)[:, 37:261]


def crop_tile(output) -> np.ndarray:
    """The 112 px colour crop above its mask, centred on a black TILE square."""
    canvas = np.zeros((TILE, TILE, 3), np.uint8)
    canvas[:112, 56:168] = output.color_crop
    canvas[112:, 56:168] = output.mask[..., None]
    return canvas


def heat(values: np.ndarray) -> np.ndarray:
    """(H, W) float saliency -> (H, W, 3) uint8 RGB, jet colour map over its own range."""
    colored = cv2.applyColorMap((normalised(values) * 255).astype(np.uint8), cv2.COLORMAP_JET)
    return cv2.cvtColor(colored, cv2.COLOR_BGR2RGB)


def saliency_picture(world, params: AttentionParams) -> np.ndarray:
    rows = []
    for scenario, seed, targets in SALIENCY_SCENES:
        record, frame = evaluation.record_from_world(world, scenario, seed, targets, NUM_OBJECTS, keep_frame=True)
        output = attend(record.color, record.height, params)
        rows.append(np.concatenate([
            tile(camera_tile(frame.color), f"camera ({scenario}, {targets} impurities)"),
            tile(record.color, "colour heightmap"), tile(heat(output.saliency), "VOCUS2 saliency"),
            tile(debug_image(record.color, output), f"{output.mode.name} {output.score:.3f}"),
            tile(crop_tile(output), "crop + mask (112 px)")], axis=1))
    return np.concatenate(rows, axis=0)


def dbscan_picture(world, params: AttentionParams) -> np.ndarray:
    scenario, seed, targets = DBSCAN_SCENE
    record, frame = evaluation.record_from_world(world, scenario, seed, targets, NUM_OBJECTS, keep_frame=True)
    output = attend(record.color, record.height, params)
    palette = np.random.default_rng(0).integers(60, 255, (len(output.clusters) + 1, 3)).astype(np.uint8)
    labels = np.zeros_like(record.color)
    for i, cluster in enumerate(output.clusters):
        labels[cluster.mask] = palette[i] if cluster.passes else (90, 90, 90)
    if output.cluster is not None:
        contours, _ = cv2.findContours(output.cluster.mask.astype(np.uint8), cv2.RETR_EXTERNAL,
                                       cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(labels, contours, -1, (255, 255, 255), 2)
    for row, col in record.target_cells:
        cv2.drawMarker(labels, (int(col), int(row)), (255, 0, 0), cv2.MARKER_CROSS, 12, 2)
    height = cv2.cvtColor((np.clip(record.height / 0.1, 0, 1) * 255).astype(np.uint8), cv2.COLOR_GRAY2RGB)
    return np.concatenate([
        tile(camera_tile(frame.color), f"camera ({scenario})"), tile(height, "height 0-10 cm"),
        tile(labels, "clusters; + hidden impurity"), tile(debug_image(record.color, output), output.mode.name),
        tile(crop_tile(output), "crop + all-one mask")], axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=pathlib.Path, default=ROOT / "docs" / "images")
    args = parser.parse_args()
    from ur5_driver_sim.core.world import CellWorld

    params = AttentionParams()
    world = CellWorld(mode="floating")
    try:
        pictures = {"attention_saliency.png": saliency_picture(world, params),
                    "attention_dbscan.png": dbscan_picture(world, params)}
    finally:
        world.close()
    args.output_dir.mkdir(parents=True, exist_ok=True)
    for name, picture in pictures.items():
        cv2.imwrite(str(args.output_dir / name), cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))
        print(f"wrote {args.output_dir / name}")


if __name__ == "__main__":
    main()
