#!/usr/bin/env python3
"""Draw docs/images/method.png: the path from a camera frame to a grasp, one box per stage, as
docs/method.md describes it (a block diagram, nothing measured).

    python scripts/draw_method.py [--output docs/images/method.png]
"""

from __future__ import annotations

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUTPUT = ROOT / "docs" / "images" / "method.png"

# (key, text, x, y, colour): box centres in axes units (0..16.5 wide, 0..11 high)
PERCEPTION, ATTENTION, POLICY, CELL = "#dbe9f6", "#fde9c9", "#dff2dd", "#eeeeee"
BOXES = (
    ("camera", "camera frame\nRGB + aligned depth", 1.5, 7.8, CELL),
    ("heightmap", "heightmap\n224 x 224 cells of 2 mm\ncolour + height", 4.8, 7.8, PERCEPTION),
    ("saliency", "salient regions\nVOCUS2, relative\nto the product", 8.1, 7.8, ATTENTION),
    ("verifier", "region verifier\n17 features, 2 from\nthe impurity network", 11.4, 7.8, ATTENTION),
    ("memory", "known product\n(first view without target)", 11.4, 10.0, ATTENTION),
    ("crops", "112 x 112 crops + mask\nTARGET: the target\nOCCLUDED_REGION: a heap", 14.9, 7.8, ATTENTION),
    ("looks", "last look / stall look\nthe likeliest region\nat a lower threshold", 8.1, 5.3, ATTENTION),
    ("dbscan", "DBSCAN heaps\nnone left and no\ntarget: NONE", 11.4, 5.3, ATTENTION),
    ("dqn", "push-grasp DQN\n16 rotations x\n(push, grasp) Q maps", 14.9, 5.3, POLICY),
    ("rules", "test-time rules\n(cell preset)\nmask the Q maps", 14.9, 2.8, POLICY),
    ("primitive", "primitive\npush 10 cm or grasp\nat (x, y, z, psi)", 11.4, 2.8, CELL),
    ("verdict", "verdict\ntarget gone, gripper\nholding, colour apart", 4.8, 2.8, POLICY),
    ("end", "episode end\n3 NONE views, action\nlimit or 5 failures", 1.5, 2.8, POLICY),
)
ARROWS = (  # (from, to, label)
    ("camera", "heightmap", ""), ("heightmap", "saliency", ""), ("saliency", "verifier", "3 best"),
    ("memory", "verifier", ""), ("verifier", "crops", "p >= 0.738"), ("verifier", "dbscan", "no target"),
    ("dbscan", "looks", "no heap left,\nor 5 heap views"), ("looks", "verifier", ""),
    ("dbscan", "crops", "heap"),
    ("crops", "dqn", ""), ("dqn", "rules", ""), ("rules", "primitive", "argmax"),
    ("primitive", "verdict", "the next view"), ("verdict", "end", ""), ("verdict", "heightmap", "next step"),
)
WIDTH, HEIGHT, GAP = 2.6, 1.5, 0.08


def edge_point(centre: tuple, towards: tuple) -> tuple:
    """Where the segment from a box's centre towards `towards` leaves the box (plus GAP)."""
    (x, y), (tx, ty) = centre, towards
    dx, dy = tx - x, ty - y
    scale = min((WIDTH / 2 + GAP) / abs(dx) if dx else float("inf"),
                (HEIGHT / 2 + GAP) / abs(dy) if dy else float("inf"))
    return x + dx * scale, y + dy * scale


def draw(output: pathlib.Path) -> None:
    fig, ax = plt.subplots(figsize=(16.5, 11), dpi=80)
    ax.set_xlim(0, 16.5)
    ax.set_ylim(0.4, 11)
    ax.axis("off")
    centres = {}
    for key, text, x, y, colour in BOXES:
        centres[key] = (x, y)
        ax.add_patch(FancyBboxPatch((x - WIDTH / 2, y - HEIGHT / 2), WIDTH, HEIGHT,
                                    boxstyle="round,pad=0.02", facecolor=colour, edgecolor="#444444"))
        ax.text(x, y, text, ha="center", va="center", fontsize=12)
    for start, stop, label in ARROWS:
        a, b = edge_point(centres[start], centres[stop]), edge_point(centres[stop], centres[start])
        ax.add_patch(FancyArrowPatch(a, b, arrowstyle="-|>", mutation_scale=18, color="#333333"))
        if label:
            ax.text((a[0] + b[0]) / 2, (a[1] + b[1]) / 2 + 0.08, label, fontsize=10, ha="center", va="bottom")
    legend = ((PERCEPTION, "heightmap_node", 1.0), (ATTENTION, "attention_node", 4.6),
              (POLICY, "policy_node / episode_node", 8.2), (CELL, "sim_cell / ur5_driver", 12.4))
    for colour, name, x in legend:
        ax.add_patch(FancyBboxPatch((x, 0.75), 0.4, 0.3, boxstyle="square,pad=0", facecolor=colour,
                                    edgecolor="#444444"))
        ax.text(x + 0.55, 0.9, name, va="center", fontsize=12)
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=pathlib.Path, default=OUTPUT)
    draw(parser.parse_args(argv).output)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
