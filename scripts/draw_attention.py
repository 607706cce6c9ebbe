#!/usr/bin/env python3
"""Draw docs/images/attention_saliency.png, attention_dbscan.png and palettes.png: simulator scenes
projected onto the heightmap and answered by attention with the shipped defaults
(impurity_attention.core.attention.attend).

attention_saliency.png: one row per scene (a random and a challenging scene with two impurities, a
random scene without any): camera image, colour heightmap, VOCUS2 saliency, attention's answer (mode and
score), the 112 px crop over its mask. attention_dbscan.png: an invisible scene (impurities under heaps):
camera image, height 0-10 cm, the DBSCAN clusters (grey: too low or small to hide anything; white outline:
the heap attended; red cross: a hidden impurity's centre from the simulator's ground truth), the answer,
the crop over its all-one mask. palettes.png: for every named palette (ur5_driver_sim/data/palettes.yaml),
the camera image and attention's overlay of one random scene with two impurities: the same layout under
every appearance, labelled with the palette's split. 224 px tiles; scenes from the tuning seed range
(impurity_learning.splits), so the same command draws the same pictures.

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
PALETTE_SCENE = ("random", 1001, 2)
PALETTE_COLUMNS = 3  # camera + overlay pairs per row


def answered(world, scene: tuple, params: AttentionParams, palette: str = "") -> tuple:
    """(SceneRecord, camera frame, AttentionOutput) of scene (scenario, seed, impurities) under `palette`."""
    scenario, seed, targets = scene
    record, frame = evaluation.record_from_world(world, scenario, seed, targets, NUM_OBJECTS, keep_frame=True,
                                                 palette=palette)
    return record, frame, attend(record.color, record.height, params)


def label(image: np.ndarray, text: str) -> np.ndarray:
    """`image` (rows, cols, 3) uint8 RGB with `text` written along its bottom, in place."""
    cv2.putText(image, text, (4, image.shape[0] - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1,
                cv2.LINE_AA)
    return image


def tile(image: np.ndarray, text: str) -> np.ndarray:
    """(TILE, TILE, 3) uint8 RGB: `image` resized (nearest) with `text` written along its bottom."""
    if image.shape[:2] != (TILE, TILE):
        image = cv2.resize(image, (TILE, TILE), interpolation=cv2.INTER_NEAREST)
    return label(np.ascontiguousarray(image), text)


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
    for scene in SALIENCY_SCENES:
        record, frame, output = answered(world, scene, params)
        scenario, _, targets = scene
        rows.append(np.concatenate([
            tile(camera_tile(frame.color), f"camera ({scenario}, {targets} impurities)"),
            tile(record.color, "colour heightmap"), tile(heat(output.saliency), "VOCUS2 saliency"),
            tile(debug_image(record.color, output), f"{output.mode.name} {output.score:.3f}"),
            tile(crop_tile(output), "crop + mask (112 px)")], axis=1))
    return np.concatenate(rows, axis=0)


def dbscan_picture(world, params: AttentionParams) -> np.ndarray:
    record, frame, output = answered(world, DBSCAN_SCENE, params)
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
        tile(camera_tile(frame.color), f"camera ({DBSCAN_SCENE[0]})"), tile(height, "height 0-10 cm"),
        tile(labels, "clusters; + hidden impurity"),
        tile(debug_image(record.color, output), output.mode.name),
        tile(crop_tile(output), "crop + all-one mask")], axis=1)


def palettes_picture(world, params: AttentionParams) -> np.ndarray:
    from impurity_learning.splits import palette_group
    from ur5_driver_sim.core.appearance import PALETTES

    pairs = []
    for name in PALETTES:
        record, frame, output = answered(world, PALETTE_SCENE, params, palette=name)
        pair = np.concatenate([camera_tile(frame.color), debug_image(record.color, output)], axis=1)
        pairs.append(label(np.ascontiguousarray(pair),
                           f"{name} ({palette_group(name)}): {output.mode.name} {output.score:.1f}"))
    while len(pairs) % PALETTE_COLUMNS:
        pairs.append(np.zeros_like(pairs[0]))
    columns = PALETTE_COLUMNS
    rows = [np.concatenate(pairs[i:i + columns], axis=1) for i in range(0, len(pairs), columns)]
    return np.concatenate(rows, axis=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=pathlib.Path, default=ROOT / "docs" / "images")
    args = parser.parse_args()
    from ur5_driver_sim.core.world import CellWorld

    params = AttentionParams()
    world = CellWorld(mode="floating")
    try:
        pictures = {"attention_saliency.png": saliency_picture(world, params),
                    "attention_dbscan.png": dbscan_picture(world, params),
                    "palettes.png": palettes_picture(world, params)}
    finally:
        world.close()
    args.output_dir.mkdir(parents=True, exist_ok=True)
    for name, picture in pictures.items():
        cv2.imwrite(str(args.output_dir / name), cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))
        print(f"wrote {args.output_dir / name}")


if __name__ == "__main__":
    main()
