"""Fits on fast-sim episodes counted as a real cell counts (evaluate.PerceptionSimCell: no target count,
attention's NONE ends an episode, the policy with the `cell` rules decides): the grasp verdict's colour test
and the height below which a dense cluster cannot hide anything.

An episode file is JSON lines, one episode each, appended as episodes finish (a run that stops resumes).
"""

from __future__ import annotations

import dataclasses
import gzip
import itertools
import json
import pathlib

import numpy as np

from impurity_policy.core.episode import TERMINATION_NOTHING_LEFT

from .. import splits
from .scenes import check_palettes, check_seeds

# ---------------------------------------------------------------------------------------------- verdict
VERDICT_SEED_BASE = 50_000  # tuning scene seeds, VERDICT_SEED_BASE + k
VERDICT_SCENARIOS = ("random", "challenging", "invisible")
# (num_targets, num_objects, max_actions) per scenario: small scenes and paper-sized ones (more products left
# when the last impurity is gone: more chances of a false TARGET)
VERDICT_SCENE_SIZES = {"random": [(1, 5, 15), (2, 10, 25)], "challenging": [(1, 5, 15), (2, 10, 25)],
                       "invisible": [(1, 10, 45)]}
SPREADS = (2, 4, 8, 12, 16, 20, 24, 32, 40, 48)  # least product colour spreads (RGB) tried
SHADINGS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)  # ProductReference shadings (share of the mean colour) tried
COLOUR_CONTRASTS = np.round(np.arange(0.0, 6.01, 0.25), 2)  # min_color_contrast values tried


def read_episodes(paths) -> list:
    """The episodes of JSON-lines files (.gz read as gzip)."""
    rows = []
    for path in map(pathlib.Path, paths):
        text = gzip.decompress(path.read_bytes()).decode() if path.suffix == ".gz" else path.read_text()
        rows += [json.loads(line) for line in text.splitlines() if line.strip()]
    return rows


def check_episodes(rows) -> None:
    """CalibrationRefused if an episode is of a palette or seed outside the tuning split."""
    check_palettes({row["palette"] for row in rows})
    check_seeds([row["seed"] for row in rows])


def verdict_jobs(palettes, seeds: int) -> list:
    """(scenario, (targets, objects, max_actions), palette, seed) per scenario and scene size, seeds
    VERDICT_SEED_BASE + k for k < seeds, the palettes cycled."""
    check_palettes(palettes)
    seed_list = [VERDICT_SEED_BASE + k for k in range(seeds)]
    check_seeds(seed_list)
    return [(scenario, size, palette, seed) for scenario in VERDICT_SCENARIOS
            for size in VERDICT_SCENE_SIZES[scenario]
            for palette, seed in zip(itertools.cycle(palettes), seed_list)]


def collect_verdict_episodes(jobs: list, out: pathlib.Path, checkpoint, params,
                             progress: bool = True) -> None:
    """Run the jobs without the verdict's colour test (min_color_contrast 0) and append each episode's
    grasps to `out` (jobs already there are skipped): per grasp of an attended TARGET the features the
    verdict reads and the simulator's truth; per episode the product reference's colours (every 8th), so
    the colour measure is computed when reading."""
    from tqdm import tqdm

    from impurity_policy.core import picking
    from impurity_policy.core.episode import EpisodeRequest
    from impurity_policy.core.verdict import (
        VerdictParams,
        product_color_distance,
        product_reference,
        region_color,
    )
    from ur5_driver_sim.core.world import CellWorld

    from ..agents import make_agent
    from ..evaluate import PerceptionSimCell, _reraise

    class RecordingCell(PerceptionSimCell):
        """Keeps the view each grasp was decided on, and the product reference of the first view."""

        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.last_view = self.decided_on = self.reference = None

        def observe(self):
            self.last_view = super().observe()
            if self.reference is None:
                view = self.last_view
                self.reference = product_reference(view.color, view.height, view.target_mask)
            return self.last_view

        def execute(self, action):
            self.decided_on = self.last_view
            return super().execute(action)

    out.parent.mkdir(parents=True, exist_ok=True)
    done = {(r["scenario"], r["num_objects"], r["palette"], r["seed"]) for r in read_episodes([out])} \
        if out.exists() else set()
    world = CellWorld(mode="floating")
    agent = make_agent("ours", pathlib.Path(checkpoint), "cell")
    limits = picking.EpisodeLimits(verdict=VerdictParams(min_color_contrast=0.0))
    with out.open("a") as sink:
        for scenario, (targets, objects, max_actions), palette, seed in tqdm(jobs, desc="verdict episodes",
                                                                             disable=not progress):
            if (scenario, objects, palette, seed) in done:
                continue
            cell = RecordingCell(world, agent, attention_params=params)
            grasps = []

            def on_step(step, cell=cell, grasps=grasps):
                view = cell.decided_on
                if step.kind != "grasp":
                    return
                if view is None or view.target_mask is None:  # not a TARGET: never counted as picked
                    grasps.append({"step": step.step, "target": False,
                                   "truth": bool(step.truth_target_grasped)})
                    return
                grasps.append({
                    "target": True, "step": step.step, "gone_fraction": step.gone_fraction,
                    "holding": bool(step.holding),
                    "truth": bool(step.truth_target_grasped),
                    "color_distance": product_color_distance(view.color, view.height, view.target_mask),
                    "region_rgb": region_color(view.color, view.target_mask).round(1).tolist()})

            request = EpisodeRequest(scenario, seed=seed, num_targets=targets, num_objects=objects,
                                     max_actions=max_actions, palette=palette)
            summary = picking.run_episode(cell, request, f"{scenario}-{seed}", limits, on_step=on_step,
                                          on_error=_reraise)
            reference = cell.reference.colors[::8].round().astype(int).tolist() if cell.reference else []
            sink.write(json.dumps({"scenario": scenario, "num_objects": objects, "palette": palette,
                                   "seed": seed, "termination": summary["termination_reason"],
                                   "truth_total": summary["truth_targets_total"], "grasps": grasps,
                                   "reference_rgb": reference}) + "\n")
            sink.flush()
    world.close()


def with_contrast(rows: list, min_spread: float, shading: float = 0.0) -> list:
    """Each TARGET grasp's color_contrast from the episode's reference colours (verdict.ProductReference of
    least spread `min_spread` RGB and `shading`); None without reference colours."""
    from impurity_policy.core.verdict import ProductReference

    for row in rows:
        colors = row["reference_rgb"]
        reference = ProductReference.from_colors(colors, min_spread, shading) if colors else None
        for grasp in row["grasps"]:
            if grasp["target"]:
                grasp["color_contrast"] = reference.contrast(grasp["region_rgb"]) if reference else None
    return rows


def verdict_of(grasp: dict, min_contrast: float) -> bool:
    """verdict.decide_picked on a recorded grasp at min_color_contrast = min_contrast; a grasp without an
    attended target is never a pick."""
    from impurity_policy.core.verdict import VerdictParams, decide_picked

    if not grasp["target"]:
        return False
    tried = dataclasses.replace(VerdictParams(), min_color_contrast=min_contrast)
    return decide_picked(grasp["gone_fraction"], grasp["holding"], grasp["color_contrast"], tried)[0]


def agreement(rows: list, min_contrast: float) -> dict:
    """Grasp verdicts agreeing with the truth (share; missed and false counts) and episodes whose picked
    count is the truth's."""
    checked = agreeing = episodes = matching = missed = false = 0
    for row in rows:
        picked = truth_picked = 0
        for grasp in row["grasps"]:
            decided = verdict_of(grasp, min_contrast)
            checked += 1
            agreeing += decided == grasp["truth"]
            missed += grasp["truth"] and not decided
            false += decided and not grasp["truth"]
            picked += decided
            truth_picked += grasp["truth"]
        episodes += 1
        matching += picked == truth_picked
    return {"grasps": checked, "agreement": agreeing / max(checked, 1), "missed": missed, "false": false,
            "episodes": episodes, "count_match": matching / max(episodes, 1)}


def choose_verdict(rows: list) -> dict:
    """The verdict's min_color_contrast and its product reference's least spread and shading, with the best
    agreement with the truth on the episodes; ties to the best episode count match, then the lowest
    contrast, the least spread and the least shading. Returns them with their figures. ValueError when no
    grasp of a TARGET was recorded."""
    if not any(g["target"] for r in rows for g in r["grasps"]):
        raise ValueError("no grasp of an attended TARGET in the episodes: run more episodes")

    def key(t):
        spread, contrast, figures, shading = t
        return (round(figures["agreement"], 4), round(figures["count_match"], 4), -contrast, -spread,
                -shading)

    best = None
    for shading in SHADINGS:
        for spread in SPREADS:
            with_contrast(rows, spread, shading)
            table = [(spread, c, agreement(rows, c), shading) for c in COLOUR_CONTRASTS]
            candidate = max(table, key=key)
            best = candidate if best is None else max(best, candidate, key=key)
    spread, contrast, figures, shading = best
    return {"min_color_contrast": float(contrast),
            "min_color_spread": float(spread), "color_shading": float(shading), **figures}


# ------------------------------------------------------------------------------------------ episode end
EPISODE_END_SEED_BASE = 60_000  # tuning scene seeds, base + 100 x scene + k
HEIGHTS = (0.030, 0.035, 0.040, 0.045)  # m, min_cluster_height values tried by default
# (scenario, num_targets, num_objects, max_actions): invisible scenes small and paper-sized, random clutter
# (tilted blocks make low clusters), small random and challenging scenes
END_SCENES = (("invisible", 1, 10, 45), ("invisible", 2, 20, 45), ("random", 2, 10, 25), ("random", 1, 5, 15),
              ("challenging", 1, 5, 15))


def episode_end_jobs(heights, palettes, seeds: int) -> list:
    """(height, scene, palette, seed) for every height and END_SCENES row, seeds EPISODE_END_SEED_BASE +
    100 x row + k for k < seeds, the palettes cycled."""
    check_palettes(palettes)
    scenes = [(scene, palette, EPISODE_END_SEED_BASE + 100 * index + k)
              for index, scene in enumerate(END_SCENES)
              for k, palette in zip(range(seeds), itertools.cycle(palettes))]
    check_seeds([seed for *_, seed in scenes])
    return [(float(height), *job) for height in heights for job in scenes]


def scene_set_end_jobs(heights, palettes, seeds: int, names) -> list:
    """(height, (scenario, targets, objects, 0, scene set), palette, seed) for every height, scene set of
    `names` (ur5_driver_sim.core.scenes.SCENE_SETS, or <set>@<lowest>-<highest> mm) and layout
    (scenes.UPRIGHT_LAYOUTS), on the scene sets' tuning seeds splits.scene_set_seeds("tuning", seeds), the
    palettes cycled; counts drawn by the set from the seed, the action limit the cell's (max_actions 0)."""
    from ur5_driver_sim.core.scenes import UPRIGHT_LAYOUTS, scene_set_named

    check_palettes(palettes)
    seed_list = splits.scene_set_seeds("tuning", seeds)
    check_seeds(seed_list)
    scenes = []
    for name in names:
        chosen = scene_set_named(name)
        for scenario in UPRIGHT_LAYOUTS:
            for palette, seed in zip(itertools.cycle(palettes), seed_list):
                draw = chosen.draw(seed)
                scenes.append(((scenario, draw.num_targets, draw.num_objects, 0, chosen.name), palette, seed))
    return [(float(height), *job) for height in heights for job in scenes]


def collect_end_episodes(jobs: list, out: pathlib.Path, checkpoint, params, progress: bool = True) -> None:
    """Run the jobs (attention `params` with the job's min_cluster_height; a scene of a scene set, the
    fifth field of a job's scene, with the set's piece heights) and append each episode's end to `out`
    (jobs already there are skipped)."""
    from tqdm import tqdm

    from impurity_policy.core import picking
    from impurity_policy.core.episode import EpisodeRequest
    from ur5_driver_sim.core.scenes import scene_set_named
    from ur5_driver_sim.core.world import CellWorld

    from ..agents import make_agent
    from ..evaluate import PerceptionSimCell, _reraise

    out.parent.mkdir(parents=True, exist_ok=True)
    done = {key_of(row) for row in read_episodes([out])} if out.exists() else set()
    world = CellWorld(mode="floating")
    agent = make_agent("ours", pathlib.Path(checkpoint), "cell")
    with out.open("a") as sink:
        for height, (scenario, targets, objects, max_actions, *scene_set), palette, seed in tqdm(
                jobs, desc="episode-end episodes", disable=not progress):
            scene_set = scene_set[0] if scene_set else ""
            if (height, scenario, targets, objects, palette, seed, scene_set) in done:
                continue
            tried = dataclasses.replace(params, density=dataclasses.replace(params.density,
                                                                            min_cluster_height=height))
            heights = scene_set_named(scene_set).heights if scene_set else None
            cell = PerceptionSimCell(world, agent, attention_params=tried, piece_heights=heights)
            request = EpisodeRequest(scenario, seed=seed, num_targets=targets, num_objects=objects,
                                     max_actions=max_actions, palette=palette)
            summary = picking.run_episode(cell, request, f"{scenario}-{seed}", picking.EpisodeLimits(),
                                          on_error=_reraise)
            sink.write(json.dumps({"height": height, "scenario": scenario, "num_targets": targets,
                                   "num_objects": objects, "palette": palette, "seed": seed,
                                   **({"scene_set": scene_set} if scene_set else {}),
                                   "termination": summary["termination_reason"],
                                   "actions": summary["actions"],
                                   "picked": summary["targets_picked"],
                                   "truth_picked": summary["truth_targets_picked"],
                                   "truth_total": summary["truth_targets_total"]}) + "\n")
            sink.flush()
    world.close()


def key_of(row: dict) -> tuple:
    return row["height"], *scene_of(row)


def scene_of(row: dict) -> tuple:
    return (row["scenario"], row["num_targets"], row["num_objects"], row["palette"], row["seed"],
            row.get("scene_set", ""))


def end_figures(rows: list) -> dict:
    """clean_end: share ended by attention's NONE with no impurity left (the truth); ended_by_none;
    left_behind: episodes ended by NONE with an impurity left; completion; mean actions; count_match: the
    perception count equals the truth's."""
    n = len(rows)
    by_none = [r["termination"] == TERMINATION_NOTHING_LEFT for r in rows]
    complete = [r["truth_picked"] >= r["truth_total"] for r in rows]
    return {"episodes": n,
            "clean_end": sum(a and b for a, b in zip(by_none, complete, strict=True)) / max(n, 1),
            "ended_by_none": sum(by_none) / max(n, 1),
            "left_behind": sum(a and not b for a, b in zip(by_none, complete, strict=True)),
            "completion": sum(complete) / max(n, 1),
            "actions": float(np.mean([r["actions"] for r in rows])) if rows else 0.0,
            "count_match": sum(r["picked"] == r["truth_picked"] for r in rows) / max(n, 1)}


def common_scenes(rows: list) -> list:
    """The rows of the scenes every height ran: heights are compared on the same scenes only."""
    heights = {r["height"] for r in rows}
    shared = set.intersection(*({scene_of(r) for r in rows if r["height"] == h} for h in heights))
    return [r for r in rows if scene_of(r) in shared]


def choose_height(rows: list) -> tuple:
    """(min_cluster_height with the most clean ends on the scenes every height ran, ties to the lowest: the
    least a cell is told to ignore; {height: end_figures} on those scenes). ValueError on no rows."""
    if not rows:
        raise ValueError("no episodes to choose from")
    rows = common_scenes(rows)
    heights = sorted({r["height"] for r in rows})
    table = {h: end_figures([r for r in rows if r["height"] == h]) for h in heights}
    chosen = max(table, key=lambda h: (round(table[h]["clean_end"], 6), -h))
    return chosen, table


def default_palettes(random_count: int) -> list:
    return splits.tuning_palettes(random_count)
