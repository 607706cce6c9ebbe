#!/usr/bin/env python3
"""Draw docs/images/architecture.png: the simulated cell's node graph (impurity_bringup.cell_nodes), one box
per node process, one arrow per topic (publisher -> subscriber), service (caller -> server) and action
(client -> server). The edges are read from the node modules by scripts/node_reference.py, so the figure
shows the names the code uses; only the boxes' places are set here.

    python scripts/draw_architecture.py [--output docs/images/architecture.png]

Needs `source scripts/env.sh` (it imports the node modules).
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import math
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUTPUT = ROOT / "docs" / "images" / "architecture.png"
CLIENT = "episode client\n(make demo, ros2 action send_goal)"

# executable -> box centre (axes units, 0..18 wide, 0..10 high); the client is not a node of the graph
PLACES = {
    "sim_cell": (2.6, 5.5),
    "heightmap_node": (6.5, 8.6),
    "attention_node": (11.0, 8.6),
    "policy_node": (15.6, 8.6),
    "episode_node": (11.0, 3.2),
    "decision_markers": (15.6, 3.2),
    "cell_state_publisher": (2.6, 1.4),
    CLIENT: (6.5, 1.4),
}
COLOURS = {"ur5_driver_sim": "#eeeeee", "impurity_attention": "#fde9c9", "impurity_policy": "#dff2dd",
           "impurity_common": "#dbe9f6", "impurity_viz": "#dbe9f6"}
WIDTH, HEIGHT, GAP = 3.2, 1.1, 0.06


def node_reference():
    spec = importlib.util.spec_from_file_location("node_reference", ROOT / "scripts" / "node_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def edges() -> dict:
    """{(from, to): [label, ...]} between the executables of PLACES: topics from their publishers to their
    subscribers, services from callers to servers (marked "srv"), actions from clients to servers
    ("action"); the episode's own action from the client."""
    reference = node_reference()
    roles = {}
    for executable in PLACES:
        if executable not in reference.NODES:
            continue
        _, target, extra = reference.NODES[executable]
        found = collections.defaultdict(list)
        for module in (target.partition(":")[0], *extra):
            for role, names in reference.interfaces(module).items():
                found[role] += names
        roles[executable] = found
    result = collections.defaultdict(list)
    pairs = (("publishes", "subscribes", ""), ("calls", "serves", " (srv)"),
             ("action client", "action server", " (action)"))
    for source, sink, mark in pairs:
        for a, found_a in roles.items():
            for b, found_b in roles.items():
                if a == b:
                    continue
                for name in found_a.get(source, []):
                    if name in found_b.get(sink, []):
                        result[(a, b)].append(name + mark)
    for name in roles["episode_node"].get("action server", []):
        result[(CLIENT, "episode_node")].append(name + " (action)")
    return result


def edge_point(centre: tuple, towards: tuple) -> tuple:
    """Where the segment from a box's centre towards `towards` leaves the box (plus GAP)."""
    (x, y), (tx, ty) = centre, towards
    dx, dy = tx - x, ty - y
    scale = min((WIDTH / 2 + GAP) / abs(dx) if dx else math.inf,
                (HEIGHT / 2 + GAP) / abs(dy) if dy else math.inf)
    return x + dx * scale, y + dy * scale


def draw(output: pathlib.Path) -> None:
    reference = node_reference()
    fig, ax = plt.subplots(figsize=(18, 10), dpi=80)
    ax.set_xlim(0, 18)
    ax.set_ylim(0.3, 10)
    ax.axis("off")
    for name, (x, y) in PLACES.items():
        package = reference.NODES[name][0] if name in reference.NODES else ""
        ax.add_patch(FancyBboxPatch((x - WIDTH / 2, y - HEIGHT / 2), WIDTH, HEIGHT,
                                    boxstyle="round,pad=0.02", facecolor=COLOURS.get(package, "white"),
                                    edgecolor="#444444"))
        ax.text(x, y, f"{name}\n{package}" if package else name, ha="center", va="center", fontsize=12)
    graph = edges()
    for (a, b), labels in sorted(graph.items()):
        both_ways = (b, a) in graph
        (xa, ya), (xb, yb) = PLACES[a], PLACES[b]
        length = math.hypot(xb - xa, yb - ya)
        normal = (-(yb - ya) / length, (xb - xa) / length)  # to the left of a -> b
        shift = 0.3 if both_ways else 0.0
        start = edge_point((xa + normal[0] * shift, ya + normal[1] * shift), (xb, yb))
        stop = edge_point((xb + normal[0] * shift, yb + normal[1] * shift), (xa, ya))
        ax.add_patch(FancyArrowPatch(start, stop, arrowstyle="-|>", mutation_scale=16, color="#333333"))
        # the label 40 % of the way along, beside the arrow on its left: two ways between one pair apart
        mx = start[0] + (stop[0] - start[0]) * 0.4 + normal[0] * 0.12
        my = start[1] + (stop[1] - start[1]) * 0.4 + normal[1] * 0.12
        align = "left" if normal[0] > 0.3 else "right" if normal[0] < -0.3 else "center"
        ax.text(mx, my, "\n".join(labels), fontsize=10, ha=align, va="center", color="#1f3b73",
                bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1})
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
