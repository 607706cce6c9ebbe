"""Nineteenth session, tuning data only: a screen for a next version of grasp_along_ridge (not tested).

The revised rule (pose.ridge_direction with the crest over the middle) helped upright prisms and hurt lying
cylinders: across a round body the fingers meet it at its widest, across a tent they meet faces that narrow
upwards. This prints, for single rendered blocks and for every crest the rule read in the two tests' changed
episodes (replayed with the rule on), the flank ratio: the mean |slope| along the fall line over the outer half
of the block's width over that of the inner half (a tent's flanks are straight: about 1; a round top is flat at
its crest and steep at its sides: well above 1) and the tilt along the crest (|mean slope| along it, m/m), with
the outline's step over what lies beside it (mm), with the grasp outcomes of the episode.

    python docs/experiments_s19/tent_screen.py blocks
    python docs/experiments_s19/tent_screen.py episodes

tent_screen.txt was written just before aa1d1f4, the second revision, put the outline step into
pose.ridge_direction: run now, the screen no longer sees the lying cylinders' and the cube's crests (the
rule reads none there), and its episode replays follow the second revision.
"""
import json
import math
import pathlib
import sys
import tempfile

import cv2
import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "experiments_s14"))


def _slopes(height_crop, mask, erode: int = 2) -> tuple:
    """(rows, cols, d/drow, d/dcol) of the mask's inner cells: ridge_direction's cells and smoothing."""
    inner = cv2.erode((mask > 0).astype(np.uint8), np.ones((2 * erode + 1,) * 2, np.uint8)) > 0
    smooth = cv2.GaussianBlur(np.nan_to_num(height_crop, nan=0.0).astype(np.float32), (0, 0), 1.0)
    g_row, g_col = np.gradient(smooth)
    rows, cols = np.nonzero(inner)
    return rows, cols, g_row[rows, cols], g_col[rows, cols]


def _fall(crest: float) -> tuple:
    return math.cos(crest - math.pi / 2), math.sin(crest - math.pi / 2)


def flank_ratio(height_crop, mask, crest: float) -> float:
    """Mean |slope| along the fall line (across `crest`, rad) over the outer half of the inner cells' span over
    the inner half's."""
    rows, cols, g_row, g_col = _slopes(height_crop, mask)
    fall = _fall(crest)
    across = (cols - cols.mean()) * fall[0] + (rows - rows.mean()) * fall[1]
    slope = np.abs(g_col * fall[0] + g_row * fall[1])
    half = (np.percentile(across, 90) - np.percentile(across, 10)) / 4
    inside, outside = np.abs(across) <= half, np.abs(across) > half
    return float(slope[outside].mean() / max(slope[inside].mean(), 1e-9))


def crest_tilt(height_crop, mask, crest: float) -> float:
    """|mean slope| (m/m) along the crest over the inner cells: about 0 for a block lying level, the tangent of
    its tilt for one resting on a neighbour at one end."""
    _, _, g_row, g_col = _slopes(height_crop, mask)
    along = g_col * math.cos(crest) + g_row * math.sin(crest)
    return float(abs(along.mean()) / 0.002)  # px -> m (the heightmap's 2 mm cells)


def outline_step(height_crop, mask, crest: float) -> float:
    """m: pose.outline_step (ridge_direction's condition since the second revision) across `crest`."""
    from impurity_policy.core.pose import outline_step as step
    return step(np.nan_to_num(height_crop, nan=0.0), mask > 0, _fall(crest))


def blocks() -> None:
    import pybullet

    from impurity_attention.core.attention import AttentionParams
    from impurity_common.grid import HeightmapGrid
    from impurity_learning.train import sense
    from impurity_policy.core.pose import ridge_direction
    from ur5_driver_sim.core.world import CellWorld

    world, grid, projectors = CellWorld(mode="floating"), HeightmapGrid(), {}
    quaternion = pybullet.getQuaternionFromEuler
    cases = [("prism", (0.05, 0.056, 0.038), (0, 0, 0.3)), ("prism", (0.041, 0.053, 0.033), (0, 0, 1.0)),
             ("half_cylinder", (0.05, 0.05, 0.025), (0, 0, 0.3)), ("cylinder", (0.036, 0.036, 0.05), (1.5708, 0, 0.3)),
             ("cylinder", (0.045, 0.045, 0.04), (1.5708, 0, 1.2)), ("cube", (0.04, 0.04, 0.04), (0.785, 0, 0.3))]
    for shape, dims, rpy in cases:
        scene = [{"shape": shape, "dims": list(dims), "is_target": True, "position": [0.5, 0.0, max(dims) / 2 + 0.01],
                  "orientation": list(quaternion(rpy))}]
        with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
            json.dump(scene, f)
        world.reset_scene("file", seed=0, scene_file=f.name)
        height = sense(world, projectors, "ours", AttentionParams(), grid).maps.height
        mask = (height > 0.004).astype(np.uint8)
        crest = ridge_direction(height, mask, grid.resolution, 0.4)
        ratio = None if crest is None else round(flank_ratio(height, mask, crest), 2)
        tilt = None if crest is None else round(crest_tilt(height, mask, crest), 2)
        step = None if crest is None else round(1000 * outline_step(height, mask, crest))
        print(f"{shape:14s} {dims} rpy {rpy}: crest {None if crest is None else round(math.degrees(crest), 1)}, "
              f"flank ratio {ratio}, tilt along the crest {tilt}, outline step {step} mm")


def episodes() -> None:
    import push_out

    from impurity_policy.core import rules
    from impurity_policy.core.pose import ridge_direction

    reads = []
    original = rules.GraspAlongRidge.keeps

    def keeps(self, ctx):
        if ctx.target_in_view:
            crest = ridge_direction(ctx.obs.height_crop, ctx.obs.mask, ctx.grid.resolution,
                                    ctx.params.ridge_min_slope)
            if crest is not None:
                reads.append((round(flank_ratio(ctx.obs.height_crop, ctx.obs.mask, crest), 2),
                              round(crest_tilt(ctx.obs.height_crop, ctx.obs.mask, crest), 2),
                              round(1000 * outline_step(ctx.obs.height_crop, ctx.obs.mask, crest))))
        return original(self, ctx)

    rules.GraspAlongRidge.keeps = keeps
    for name in ("ridge", "ridge2"):
        shipped = {json.loads(line)["seed"]: json.loads(line) for line in open(HERE / f"episodes/{name}_shipped.jsonl")}
        for line in open(HERE / f"episodes/{name}_ridge.jsonl"):
            row = json.loads(line)
            base = shipped[row["seed"]]
            if (row["actions"], row["picked"], row["attempts"]) == (base["actions"], base["picked"], base["attempts"]):
                continue
            reads.clear()
            push_out.run_one((row["scenario"], row["seed"], row["palette"], {"with": ["grasp_along_ridge"]}))
            grasps = lambda r: "".join("T" if g["target"] else "x" for g in r["grasps"])  # noqa: E731
            print(f"{name:6s} {row['scenario'][:4]} {row['seed']}: shipped {grasps(base)}, with the rule "
                  f"{grasps(row)}; its crest reads (flank ratio, tilt along the crest, outline step mm) {reads}")


if __name__ == "__main__":
    {"blocks": blocks, "episodes": episodes}[sys.argv[1]]()
