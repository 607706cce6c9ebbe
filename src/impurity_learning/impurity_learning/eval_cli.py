"""`make eval`: the paper's comparison (Fig. 10, Table I) in the fast sim, every method side by side.

For each scenario (random, challenging, invisible) and method, N episodes on the held-out seeds
EVAL_SEED_BASE + k; metrics as paper 6.1 (per episode, then averaged): grasp success = targets
picked / grasp attempts, action efficiency = targets picked / actions; also completion (every target
picked) and false rejects (non-targets removed). Writes the table (docs/results.md), a Fig. 10-style
bar chart (docs/images/results.png) and every episode's record with its seed (docs/results.json).

--count perception (or both) also counts the same episodes as a real cell counts
(evaluate.run_episode(by_perception=True)): impurities picked and left, product lifted, actions and
efficiency by the truth recorded beside, with 95 % t intervals and how the episodes ended, in a section
of their own (perception_figures.py); --clean-scenes N adds N scenes per row and scenario with no
impurity. The default (--count truth) is the paper's table alone; --count perception leaves the README
block alone.

    python -m impurity_learning.eval_cli --count both --clean-scenes 10 --episodes 20   # make eval's episodes

The README block (readme_table) heads with the perception count beside the truth count, each mean with the
half width of its 95 % t interval; docs/results.md gives the truth-counted figures with their intervals.

--scene-set runs scenes beyond the paper's blocks (ur5_driver_sim.core.scenes.SCENE_SETS: tall, flat, mixed
15-60 mm, sparse, dense, clean; --piece-heights LOW HIGH in mm) on the random and challenging layouts, on
evaluation seeds (only measured) or, with --split tuning, on the tuning seeds end rules may be fitted on
(splits.SCENE_SET_TUNING_SEEDS). Such a run writes under runs/eval/<set>-<split>/, never the README block:

    python -m impurity_learning.eval_cli --scene-set sparse --split tuning --methods ours --count both \
        --episodes 4 --palette-groups default

Network methods load `<checkpoint-dir>/<trained method>.pt` (Ours: `--policy-checkpoint`, the shipped
policy.pt); a
method without a checkpoint is listed as not trained, with the command that trains it.

With palette groups (generalisation.py), the same rows also run `--group-episodes` episodes per
scenario on the tuning and held-out palettes, counted as --count says (with perception, as many clean
scenes of the group's palettes too; their rows in the perception section name the group), and the
attention module alone is measured on rendered scenes of every group: docs/generalisation.md,
docs/images/generalisation.png and docs/images/generalisation_scenes.png.

    python -m impurity_learning.eval_cli --episodes 20
    python -m impurity_learning.eval_cli --methods ours s_rgm --scenarios random --episodes 3
    python -m impurity_learning.eval_cli --methods ours --palette-groups default held_out --group-episodes 8

Episodes run in this process (--jobs 1), in a local process pool (--jobs N, default 2) or on Ray
(--ray starts a local runtime, --ray-address ADDR joins a cluster; --jobs actors, 0 = one per
CPU of the cluster; ray_eval.py). All three call run_task, so the records are the same. Each record is
appended to a journal (--journal, default the --json path with .partial.jsonl) as its episode ends; a
run interrupted part-way and started again with the same arguments runs only the episodes missing
from it (the same row, checkpoint bytes, decision settings, scenario, seed, group, palette and device);
the journal is removed once the results are written. --no-resume starts afresh. SIGTERM (a supervisor,
`kill`) stops a run as Ctrl-C does: the pool's workers finish the episodes they hold and exit with it,
and the journal keeps every finished episode.

    python -m impurity_learning.eval_cli --ray --jobs 2 --episodes 20
    python -m impurity_learning.eval_cli --ray-address 10.0.0.5:6379 --jobs 0 --episodes 20
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import hashlib
import json
import math
import os
import pathlib
import signal
import sys
import threading
import time

import numpy as np

from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
from impurity_policy.core.episode import EpisodeRequest
from impurity_policy.core.rules import PRESETS
from ur5_driver_sim.core.scenes import SCENE_SETS, UPRIGHT_LAYOUTS, scene_set_named

from . import generalisation, perception_figures, ray_runtime, splits
from .agents import EVAL_METHODS, HEURISTIC_METHODS, TRAINED_METHOD, make_agent
from .evaluate import EVAL_SEED_BASE, run_episode  # noqa: F401 (EVAL_SEED_BASE: for callers)
from .train_cli import BASELINE_CHECKPOINT_DIR

MARKDOWN = "docs/results.md"  # make eval's table; outputs not given go beside it (generalisation_outputs)
README = "README.md"  # the repository's README, whose results block a run with the default MARKDOWN replaces
SCENE_SET_OUTPUTS = "runs/eval"  # a run on a scene set or on tuning seeds writes beside <this>/<set>-<split>/
SCENARIOS = ("random", "challenging", "invisible")
LABELS = {"ours": "Ours", "vpg": "VPG", "s_vpg": "S-VPG", "s_rgm": "S-RGM (heuristic)", "no_tsd": "No-TSD",
          "no_oi": "No-OI", "no_t": "No-T"}
# Paper section 6.3 (Fig. 10 text and Table I): grasp success % and action efficiency %, per scenario.
# None where the paper gives no figure ("about 5 %" / "about 1 %" for VPG and S-VPG in invisible scenes).
PAPER = {
    "ours": ((78.1, 69.4, 78.5), (46.3, 45.1, 16.8)),
    "vpg": ((34.6, 25.4, None), (18.9, 5.3, None)),
    "s_vpg": ((52.6, 32.0, None), (26.5, 4.4, None)),
    "s_rgm": ((46.2, 22.4, 20.0), (15.4, 6.5, 2.2)),
    "no_tsd": ((34.6, 25.4, 5.1), (18.9, 5.3, 0.6)),
    "no_oi": ((53.6, 49.7, 15.7), (34.5, 29.3, 8.9)),
    "no_t": ((64.5, 62.2, 27.2), (35.8, 36.3, 7.5)),
}


def checkpoint_for(method: str, checkpoint_dir: pathlib.Path, ours: pathlib.Path) -> pathlib.Path | None:
    """The checkpoint a network method runs: `ours` for Ours, `<checkpoint_dir>/<trained method>.pt`
    for the baselines and ablations, None for the heuristic."""
    if method not in TRAINED_METHOD:
        return None
    trained = TRAINED_METHOD[method]
    return ours if trained == "ours" else checkpoint_dir / f"{trained}.pt"


def shown_path(path: pathlib.Path) -> str:
    """Paths in the committed tables are relative to where make runs, not this machine's checkout."""
    relative = os.path.relpath(path)
    return path.as_posix() if relative.startswith("..") else relative


def file_digest(path: pathlib.Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:12]


def aggregate(episodes: list) -> dict:
    """Paper 6.1 metrics averaged over episodes, in percent; plus totals, and under "intervals" the 95 % t
    interval (perception_figures.mean_interval) of grasp success, action efficiency (%) and actions."""
    def mean(key):
        return 100.0 * float(np.mean([e[key] for e in episodes])) if episodes else math.nan

    interval = perception_figures.mean_interval
    return {"episodes": len(episodes), "grasp_success": mean("grasp_success"),
            "action_efficiency": mean("action_efficiency"), "completion": mean("completed"),
            "false_rejects": int(sum(e["false_rejects"] for e in episodes)),
            "actions_mean": float(np.mean([e["actions"] for e in episodes])) if episodes else math.nan,
            "targets_picked": int(sum(e["targets_picked"] for e in episodes)),
            "targets_total": int(sum(e["targets_total"] for e in episodes)),
            "intervals": {"grasp_success": interval(100.0 * e["grasp_success"] for e in episodes),
                          "action_efficiency": interval(100.0 * e["action_efficiency"] for e in episodes),
                          "actions": interval(e["actions"] for e in episodes)}}


def row_key(method: str, rules: str) -> str:
    """A results row: a network method under a rules preset ("ours@cell"); the heuristic has no rules."""
    return method if method in HEURISTIC_METHODS else f"{method}@{rules}"


def method_of(row: str) -> str:
    return row.split("@")[0]


def label(row: str) -> str:
    method, _, rules = row.partition("@")
    return LABELS[method] + (f" [rules: {rules}]" if rules else "")


def percent(value) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{value:.1f}"


def with_interval(entry: dict, key: str) -> str:
    """A truth-counted figure with its 95 % t interval, "59.2 [41.0, 77.4]" (the mean alone for records
    aggregated without intervals)."""
    figure = entry.get("intervals", {}).get(key)
    return perception_figures.shown(figure) if figure else percent(entry.get(key, entry.get(f"{key}_mean")))


def results_table(results: dict, rows, scenarios) -> str:
    """Markdown, Table I style: grasp success and action efficiency per scenario with 95 % t intervals in
    brackets (the paper's figure after them), actions per scene, completion and false rejects; counted by
    the simulator's truth."""
    sections = []
    for title, key, column in (("Grasp success, %", "grasp_success", 0),
                               ("Action efficiency, %", "action_efficiency", 1),
                               ("Actions per scene", "actions", None),
                               ("Completion (every target picked), %", "completion", None)):
        lines = [f"**{title}**" + (" [95 % interval] (paper)" if column is not None else
                                   " [95 % interval]" if key == "actions" else ""), "",
                 "| Method | " + " | ".join(scenarios) + " |", "|---|" + "---|" * len(scenarios)]
        for row in rows:
            entry = results[row]
            if entry.get("missing"):
                cells = ["not trained"] * len(scenarios)
            elif key == "actions":
                cells = [with_interval(entry["scenarios"][s], "actions") for s in scenarios]
            elif column is not None:
                paper = PAPER[method_of(row)][column]
                cells = [f"{with_interval(entry['scenarios'][s], key)} ({percent(paper[SCENARIOS.index(s)])})"
                         for s in scenarios]
            else:
                cells = [percent(entry["scenarios"][s][key]) for s in scenarios]
            lines.append(f"| {label(row)} | " + " | ".join(cells) + " |")
        sections.append("\n".join(lines))
    lines = ["**False rejects (non-targets grasped) / targets picked of total**", "",
             "| Method | " + " | ".join(scenarios) + " |", "|---|" + "---|" * len(scenarios)]
    for row in rows:
        entry = results[row]
        cells = (["not trained"] * len(scenarios) if entry.get("missing") else
                 [f"{entry['scenarios'][s]['false_rejects']} / {entry['scenarios'][s]['targets_picked']} of "
                  f"{entry['scenarios'][s]['targets_total']}" for s in scenarios])
        lines.append(f"| {label(row)} | " + " | ".join(cells) + " |")
    sections.append("\n".join(lines))
    return "\n\n".join(sections)


def plus_minus(figure: dict | None, digits: int = 1) -> str:
    """"41.0 ± 8.6": a mean_interval dict as its mean and the half width of its interval ("41.0" without
    one, "–" without a mean)."""
    if not figure or not math.isfinite(figure["mean"]):
        return "–"
    if not math.isfinite(figure["low"]):
        return f"{figure['mean']:.{digits}f}"
    return f"{figure['mean']:.{digits}f} ± {(figure['high'] - figure['low']) / 2:.{digits}f}"


def readme_table(results: dict, rows, scenarios) -> str:
    """The README's results block: the same episodes counted by perception (as a real cell counts; the
    headline) and by the simulator's truth, means ± the half width of their 95 % t intervals. Action
    efficiency (perception / truth, the paper's figure in parentheses); actions per scene (perception /
    truth, and on clean scenes by perception); impurities left behind and product lifted per scene with
    the episodes the cell ended itself ("nothing left", of all), counted by perception; grasp success by
    truth (paper). "–": not counted that way in the run the block comes from."""
    def perception(row, scenario):
        counted = results[row].get("by_perception") or {}
        return counted.get("scenarios", {}).get(scenario) or {}

    def clean(row):
        counted = results[row].get("by_perception") or {}
        return [e for e in counted.get("episodes", []) if e.get("clean_scene")]

    def truth(row, scenario, key):
        return results[row]["scenarios"][scenario].get("intervals", {}).get(key) or {
            "mean": results[row]["scenarios"][scenario]["actions_mean" if key == "actions" else key],
            "low": math.nan, "high": math.nan}

    def efficiency(row, s):
        paper = PAPER[method_of(row)][1][SCENARIOS.index(s)]
        return (f"{plus_minus(perception(row, s).get('efficiency'))} / "
                f"{plus_minus(truth(row, s, 'action_efficiency'))} ({percent(paper)})")

    def actions(row, s):
        return f"{plus_minus(perception(row, s).get('actions'))} / {plus_minus(truth(row, s, 'actions'))}"

    def left(row, s):
        f = perception(row, s)
        if not f.get("episodes"):
            return "–"
        return (f"{plus_minus(f['left'], 2)} / {plus_minus(f['product_lifted'], 2)} · "
                f"{f['ended']['nothing_left']} of {f['episodes']}")

    def success(row, s):
        paper = PAPER[method_of(row)][0][SCENARIOS.index(s)]
        return f"{plus_minus(truth(row, s, 'grasp_success'))} ({percent(paper)})"

    def clean_cell(row):
        episodes = clean(row)
        if not episodes:
            return "–"
        figures = perception_figures.clean_figures(episodes)
        return f"{plus_minus(figures['actions'])} / {plus_minus(figures['product_lifted'], 2)}"

    tables = (("Action efficiency, %: counted by perception / by truth (paper)", efficiency, None),
              ("Actions per scene: by perception / by truth", actions,
               ("clean scenes: actions / product lifted", clean_cell)),
              ("By perception, per scene: impurities left behind / product lifted · ended \"nothing left\"",
               left, None),
              ("Grasp success, % (by truth; paper)", success, None))
    sections = []
    for title, cell, extra in tables:
        header = [*scenarios, *([extra[0]] if extra else [])]
        lines = [f"**{title}**", "", "| Method | " + " | ".join(header) + " |",
                 "|---|" + "---|" * len(header)]
        for row in rows:
            if results[row].get("missing"):
                cells = ["not trained"] * len(header)
            else:
                cells = [cell(row, s) for s in scenarios] + ([extra[1](row)] if extra else [])
            lines.append(f"| {label(row)} | " + " | ".join(cells) + " |")
        sections.append("\n".join(lines))
    return "\n\n".join(sections)


def plot_results(results: dict, rows, scenarios, path: pathlib.Path) -> None:
    """Fig. 10 style: grasp success (left) and action efficiency (right), bars per method and scenario."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = [r for r in rows if not results[r].get("missing")]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.8 / max(len(shown), 1)
    x = np.arange(len(scenarios))
    for axis, key, title in ((axes[0], "grasp_success", "Grasp success (%)"),
                             (axes[1], "action_efficiency", "Action efficiency (%)")):
        for i, row in enumerate(shown):
            values = [results[row]["scenarios"][s][key] for s in scenarios]
            bars = axis.bar(x + (i - (len(shown) - 1) / 2) * width, values, width, label=label(row))
            axis.bar_label(bars, fmt="%.0f", fontsize=7)
        axis.set_xticks(x, scenarios)
        axis.set_ylim(0, 105)
        axis.set_title(title)
        axis.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper right")
    missing = [label(r) for r in rows if results[r].get("missing")]
    note = f"not trained yet: {', '.join(missing)}" if missing else ""
    fig.suptitle(f"Fast-sim evaluation, {results['_meta']['episodes']} episodes per method and scenario "
                 f"(held-out seeds). {note}", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_markdown(results: dict, rows, scenarios, path: pathlib.Path, chart: pathlib.Path, command: str):
    meta = results["_meta"]
    scene_set = meta.get("scene_set", "paper")
    split = meta.get("split", "evaluation")
    seeds = ("held-out seeds" if split == "evaluation" else "tuning seeds")
    scenes = ("the paper's scenes" if scene_set == "paper" else
              f"scene set `{scene_set}` ({scene_set_named(scene_set).meaning})")
    lines = ["# Evaluation results (fast sim)", "",
             f"Generated by `{command}` on {meta['date']} in {meta['seconds']:.0f} s. "
             f"{meta['episodes']} episodes per method and scenario, {scenes}, on the {seeds} "
             f"{meta['seed_base']} … {meta['seed_base'] + meta['episodes'] - 1} (training scenes use "
             "run seed × 1 000 003 + scene index). Floating-gripper sim, the same sensing as training, "
             "greedy decisions; episode limits: 15 actions per target, 5 consecutive failures.", "",
             "Metrics as the paper (section 6.1), counted by the simulator's truth, averaged over episodes: "
             "grasp success = targets picked / grasp attempts; action efficiency = targets picked / actions; "
             "completion = every target picked. Beside each mean its 95 % t interval over episodes in "
             "brackets (Student's t, n - 1 degrees of freedom; – with fewer than two), then the paper's "
             "figure in parentheses. The same episodes counted by perception, as a real cell counts: the "
             "section below (with `--count both`).", "",
             results_table(results, rows, scenarios), "",
             f"![results]({os.path.relpath(chart, path.parent)})", "",
             "## Checkpoints", ""]
    for row in rows:
        entry = results[row]
        if entry.get("missing"):
            lines.append(f"- {label(row)}: no checkpoint at `{entry['checkpoint']}` — train it with "
                         f"`make train TRAIN_ARGS=\"--method {TRAINED_METHOD[method_of(row)]} --run-dir "
                         f"runs/{TRAINED_METHOD[method_of(row)]} --export {entry['checkpoint']}\"`")
        elif entry.get("checkpoint"):
            lines.append(f"- {label(row)}: `{entry['checkpoint']}` (sha256 {entry['sha256']})")
        else:
            lines.append(f"- {label(row)}: no network (heuristic)")
    path.write_text("\n".join(lines) + "\n")


README_START, README_END = "<!-- results:start -->", "<!-- results:end -->"


def update_readme(readme: pathlib.Path, table: str, markdown: pathlib.Path) -> bool:
    """Replace the README's results block (between the markers) with the new table; False when the
    README has no such block."""
    if not readme.is_file():
        return False
    text = readme.read_text()
    start, end = text.find(README_START), text.find(README_END)
    if start < 0 or end < start:
        return False
    block = f"{README_START}\n{table}\n\n(from `{markdown}`)\n{README_END}"
    readme.write_text(text[:start] + block + text[end + len(README_END):])
    return True


_WORKER: dict = {}  # per process: the sim world and each method's agent, built on first use


# A task's counting: by truth; by perception; by perception on a clean scene (built with no impurity).
COUNTS = ("truth", "perception", "clean")


def run_task(task: tuple) -> dict:
    """One evaluation episode (row, checkpoint, scenario, seed, torch threads, device, palette group,
    palette, count: one of COUNTS[, scene set]) -> its record; runs in the main process or in a pool worker.
    row: row_key(method, rules). A record counted by perception also says whether its scene was clean
    (clean_scene: built with no impurity). The scene set (a name for scenes.scene_set_named; "" or absent:
    the paper's scenes) draws the scene's counts and piece heights from its seed; its records name it
    (scene_set) with the counts drawn."""
    import torch

    from ur5_driver_sim.core.scenes import scene_set_named
    from ur5_driver_sim.core.world import CellWorld

    row, checkpoint, scenario, seed, threads, device, group, palette, count = task[:9]
    scene_set = task[9] if len(task) > 9 else ""
    method, _, rules = row.partition("@")
    if "world" not in _WORKER:
        torch.set_num_threads(threads)
        _WORKER["world"] = CellWorld(mode="floating")
    agents = _WORKER.setdefault("agents", {})
    if row not in agents:
        agents[row] = make_agent(method, pathlib.Path(checkpoint) if checkpoint else None, rules or "none",
                                 device)
    world, agent = _WORKER["world"], agents[row]
    request, heights, drawn = EpisodeRequest(scenario, seed=seed, palette=palette), None, {}
    if scene_set:
        draw = scene_set_named(scene_set).draw(seed)
        heights = draw.heights
        if draw.num_targets >= 0:
            request = dataclasses.replace(request, num_targets=draw.num_targets, num_objects=draw.num_objects)
        drawn = {"scene_set": scene_set, "num_targets": request.num_targets,
                 "num_objects": request.num_objects, "piece_heights": heights}
    if count == "truth":
        metrics = run_episode(world, agent, request, piece_heights=heights)
    else:
        if count == "clean":
            request = dataclasses.replace(request, num_targets=0)
        metrics = {**run_episode(world, agent, request, by_perception=True, piece_heights=heights),
                   "clean_scene": count == "clean" or request.num_targets == 0}
    return {"method": method, "rules": rules, "row": row, "scenario": scenario, "seed": seed, "group": group,
            "palette": palette, **drawn, **metrics}


def close_worker() -> None:
    if "world" in _WORKER:
        _WORKER.pop("world").close()
    _WORKER.pop("agents", None)


def model_files() -> dict:
    """The attention model files an episode reads besides the policy checkpoint (whose bytes task_key holds):
    name -> path of the shipped verifier.json and impurity_net.pt (impurity_attention's checkpoints dir)."""
    from impurity_attention.core.checkpoints import shipped_path
    from impurity_attention.core.impurity_net import SHIPPED_NETWORK
    from impurity_attention.core.verifier import SHIPPED_VERIFIER

    return {name: shipped_path(name) for name in (SHIPPED_VERIFIER, SHIPPED_NETWORK.name)}


@functools.cache
def settings_digest() -> str:
    """12 hex digits of sha256 over the decision settings an episode runs with besides the checkpoint: the
    attention's, the rules' and the episode limits' defaults (AttentionParams, RuleParams, EpisodeLimits)
    and the sha256 of each of model_files() (none for a missing file). A journal written before a threshold
    or a model file changed then no longer resumes into a run after it."""
    from impurity_attention.core.attention import AttentionParams
    from impurity_policy.core.picking import EpisodeLimits
    from impurity_policy.core.rules import RuleParams

    settings = {type(params).__name__: dataclasses.asdict(params)
                for params in (AttentionParams(), RuleParams(), EpisodeLimits())}
    settings["model_files"] = {name: hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
                               for name, path in model_files().items()}
    return hashlib.sha256(json.dumps(settings, sort_keys=True, default=str).encode()).hexdigest()[:12]


def task_key(task: tuple, digests: dict) -> str:
    """What makes an episode's record: row, the checkpoint's bytes (digests: path -> sha256), the decision
    settings (settings_digest), scenario, seed, device, group, palette, unless by truth the count, and
    unless the paper's the scene set (not the torch threads, not where the checkpoint lies)."""
    row, checkpoint, scenario, seed, _threads, device, group, palette, count = task[:9]
    scene_set = task[9] if len(task) > 9 else ""
    key = [row, digests.get(checkpoint, ""), settings_digest(), scenario, seed, device, group, palette]
    key = key if count == "truth" else [*key, count]
    return json.dumps([*key, scene_set] if scene_set else key)


def read_journal(path: pathlib.Path) -> dict:
    """The records a journal holds, by task key; a line cut short by an interrupted write is skipped."""
    done = {}
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                entry = json.loads(line)
                done[entry["key"]] = entry["record"]
            except (ValueError, KeyError, TypeError):
                continue
    return done


def episode_records(tasks: list, args):
    """(task, record) of every task in completion order: here (--jobs 1), in a process pool (--jobs N) or
    on Ray (--ray, --ray-address); each record is run_task(task)."""
    if args.ray or args.ray_address:
        from . import ray_eval

        yield from ray_eval.episodes(tasks, args.jobs, args.ray_address, args.threads)
    elif args.jobs > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # spawn: a fresh interpreter per worker (no forked torch thread pools or pybullet clients);
        # a worker that dies raises BrokenProcessPool here instead of hanging the run
        with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {pool.submit(run_task, task): task for task in tasks}
            try:
                for future in as_completed(futures):
                    yield futures[future], future.result()
            finally:
                for future in futures:
                    future.cancel()
    else:
        try:
            for task in tasks:
                yield task, run_task(task)
        finally:
            close_worker()


def run_episodes(tasks: list, digests: dict, journal: pathlib.Path, args) -> list:
    """Every task's record: those already in the journal, then the others, each appended to the journal
    as its episode ends (an interrupted run keeps what it finished)."""
    from tqdm import tqdm

    done = read_journal(journal)
    keys = [task_key(task, digests) for task in tasks]
    episodes = [done[key] for key in keys if key in done]
    todo = [task for task, key in zip(tasks, keys, strict=True) if key not in done]
    if episodes:
        print(f"eval: resuming: {len(episodes)} of {len(tasks)} episodes are in {journal}", file=sys.stderr)
    journal.parent.mkdir(parents=True, exist_ok=True)
    if journal.is_file() and journal.stat().st_size and not journal.read_bytes().endswith(b"\n"):
        with open(journal, "a") as out:
            out.write("\n")  # a line cut short by a killed run stays alone (and is skipped)
    with open(journal, "a") as out, tqdm(total=len(tasks), initial=len(episodes), desc="eval", unit="episode",
                                         disable=args.no_progress, dynamic_ncols=True) as bar:
        for task, record in episode_records(todo, args):
            out.write(json.dumps({"key": task_key(task, digests), "record": record}, default=float) + "\n")
            out.flush()
            episodes.append(record)
            bar.set_postfix_str(f"{record['scenario']} {label(record['row'])}")
            bar.update(1)
    return episodes


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--methods", nargs="+", default=list(EVAL_METHODS), choices=EVAL_METHODS)
    p.add_argument("--scenarios", nargs="+", default=None, choices=SCENARIOS,
                   help="default: all three; with a scene set other than paper, random and challenging (the "
                        "layouts that take piece heights)")
    p.add_argument("--rules", nargs="+", default=["cell"], choices=sorted(PRESETS),
                   help="test-time rules presets; every network method runs under each (none: the paper's "
                        "argmax, cell: our rules)")
    p.add_argument("--episodes", type=int, default=20, help="per method and scenario")
    p.add_argument("--seed-base", type=int, default=None,
                   help="episode k runs on scene seed base + k (default: the --split's first seed)")
    p.add_argument("--split", default="evaluation", choices=splits.SCENE_SET_SPLITS,
                   help="scene seeds: evaluation (EVAL_SEED_BASE + k, only measured) or tuning (splits."
                        "SCENE_SET_TUNING_SEEDS: what end rules and thresholds may be fitted on)")
    p.add_argument("--scene-set", default="paper", metavar="SET",
                   help="the scenes: " + "; ".join(f"{s.name}: {s.meaning}" for s in SCENE_SETS.values())
                        + " (ur5_driver_sim.core.scenes.SCENE_SETS; SET@LOW-HIGH: with piece heights "
                        "LOW-HIGH mm)")
    p.add_argument("--piece-heights", type=float, nargs=2, default=None, metavar=("LOW", "HIGH"),
                   help="mm: every piece of the scene set stands upright with a height in LOW-HIGH")
    p.add_argument("--checkpoint-dir", default=str(BASELINE_CHECKPOINT_DIR),
                   help="the baselines' and ablations' networks, <trained method>.pt")
    p.add_argument("--policy-checkpoint", default=str(SHIPPED_CHECKPOINT), help="Ours: the shipped network")
    p.add_argument("--markdown", default=None,
                   help=f"the results (default: {MARKDOWN} for the paper's scenes on evaluation seeds, else "
                        f"{SCENE_SET_OUTPUTS}/<set>-<split>/results.md)")
    p.add_argument("--chart", default=None,
                   help="the results chart (default: images/results.png beside --markdown)")
    p.add_argument("--json", default=None,
                   help="every episode's metrics and seed (default: results.json beside --markdown)")
    p.add_argument("--readme", default=None,
                   help="its results block is replaced with the table (default: README.md when --markdown is "
                        "left at its default, else README.md beside --markdown, updated only if it exists)")
    p.add_argument("--threads", type=int, default=1, help="torch CPU threads per episode process")
    p.add_argument("--device", default="cpu", help="cpu, cuda, cuda:N, or auto (CUDA when present)")
    p.add_argument("--jobs", type=int, default=2,
                   help="episodes run in this many processes at once (with Ray: actors; 0 = one per CPU)")
    p.add_argument("--ray", action="store_true", help="run the episodes on a local Ray runtime (ray_eval.py)")
    p.add_argument("--ray-address", default=None, metavar="ADDR",
                   help="run the episodes on the Ray cluster whose head is at ADDR (host:port, or auto)")
    p.add_argument("--journal", default=None,
                   help="every finished episode's record, read back on a resumed run (default: --json's "
                        "path with .partial.jsonl; removed when the run completes)")
    p.add_argument("--no-resume", action="store_true", help="ignore (and replace) an existing journal")
    p.add_argument("--palette-groups", nargs="+", default=list(generalisation.DEFAULT_GROUPS),
                   choices=generalisation.GROUPS,
                   help="generalisation table groups (default: the main table's episodes; tuning, held_out, "
                        "lightness: --group-episodes more per row and scenario, palettes cycling; default: "
                        f"{' '.join(generalisation.DEFAULT_GROUPS)})")
    p.add_argument("--group-episodes", type=int, default=4, help="per row, scenario and non-default group")
    p.add_argument("--group-palette-offset", type=int, default=0, metavar="N",
                   help="episode k of a non-default group runs on its palette N + k (cycling): a run on "
                        "palettes an earlier run with fewer episodes did not reach")
    p.add_argument("--perception-scenes", type=int, default=10,
                   help="rendered scenes with (and as many without) impurities per group and scenario")
    p.add_argument("--generalisation", default=None,
                   help="the generalisation table (default: generalisation.md beside --markdown)")
    p.add_argument("--generalisation-chart", default=None,
                   help="its chart (default: images/generalisation.png beside --markdown)")
    p.add_argument("--generalisation-scenes", default=None,
                   help="its scene pictures (default: images/generalisation_scenes.png beside --markdown)")
    p.add_argument("--count", default="truth", choices=("truth", "perception", "both"),
                   help="how the default group's episodes are counted: by the simulator's truth (the "
                        "paper's table), by perception as a real cell counts (perception_figures.py; a "
                        "section of its own), or both, on the same seeds (perception alone leaves the README "
                        "block alone)")
    p.add_argument("--clean-scenes", type=int, default=0, metavar="N",
                   help="also N scenes per row and scenario with no impurity, counted by perception")
    p.add_argument("--no-progress", action="store_true")
    return generalisation_outputs(scene_set_defaults(p.parse_args(argv)))


def scene_set_defaults(args):
    """Resolve the scene set (with --piece-heights) into args.scene_set, a name for scenes.scene_set_named
    ("" for the paper's scenes), and fill --scenarios, --seed-base and --markdown for it and the --split.
    A bad set or heights leave args.scene_error (main refuses them, naming the option)."""
    args.scene_error = ""
    try:
        chosen = scene_set_named(args.scene_set)
        if args.piece_heights is not None:
            chosen = chosen.with_heights(tuple(h / 1000 for h in args.piece_heights))
    except ValueError as error:
        args.scene_error, chosen = f"--scene-set/--piece-heights: {error}", SCENE_SETS["paper"]
    paper = chosen.name == "paper"
    args.scene_set = "" if paper else chosen.name
    if args.scenarios is None:
        args.scenarios = list(SCENARIOS if paper else UPRIGHT_LAYOUTS)
    if args.seed_base is None:
        args.seed_base = splits.scene_set_seeds(args.split, 1)[0]
    if args.markdown is None:
        args.markdown = (MARKDOWN if paper and args.split == "evaluation" else
                         f"{SCENE_SET_OUTPUTS}/{chosen.name.replace('@', '_')}-{args.split}/results.md")
    return args


def generalisation_outputs(args):
    """Fill the outputs not given beside --markdown (docs/results.md: docs/results.json,
    docs/images/results.png, docs/generalisation.md, docs/images/..., and the repository's README.md), so
    that a run sent elsewhere overwrites neither the committed tables and episodes nor the README's results
    block."""
    where = pathlib.Path(args.markdown).parent
    readme = pathlib.Path(README) if args.markdown == MARKDOWN else where / README
    defaults = {"json": where / "results.json", "chart": where / "images" / "results.png", "readme": readme,
                "generalisation": where / "generalisation.md",
                "generalisation_chart": where / "images" / "generalisation.png",
                "generalisation_scenes": where / "images" / "generalisation_scenes.png"}
    for name, path in defaults.items():
        if getattr(args, name) is None:
            setattr(args, name, str(path))
    return args


def _interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv=None) -> int:
    """The command line (module docstring); returns the exit status. SIGTERM raises KeyboardInterrupt
    while it runs (in the main thread), so a process pool is shut down rather than left running."""
    if threading.current_thread() is not threading.main_thread():
        return _main(argv)
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        return _main(argv)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _main(argv=None) -> int:
    import torch
    from tqdm import tqdm

    args = parse_args(argv)
    if (args.episodes < 1 or args.group_episodes < 0 or args.perception_scenes < 1
            or args.group_palette_offset < 0 or args.clean_scenes < 0):
        print("eval: --episodes and --perception-scenes must be >= 1, --group-episodes, "
              "--group-palette-offset and --clean-scenes >= 0", file=sys.stderr)
        return 2
    if args.scene_error:
        print(f"eval: {args.scene_error}", file=sys.stderr)
        return 2
    if args.scene_set and set(args.scenarios) - set(UPRIGHT_LAYOUTS):
        print(f"eval: --scene-set {args.scene_set}: scenarios {', '.join(UPRIGHT_LAYOUTS)} only "
              "(--scenarios)", file=sys.stderr)
        return 2
    seeds = [args.seed_base + k for k in range(max(args.episodes, args.clean_scenes, args.group_episodes))]
    if {splits.scene_seed_split(seed) for seed in seeds} != {args.split}:
        print(f"eval: --seed-base {args.seed_base}: seeds {seeds[0]} ... {seeds[-1]} are not all "
              f"{args.split} scene seeds (splits.SCENE_SEEDS; --split)", file=sys.stderr)
        return 2
    torch.set_num_threads(args.threads)
    if args.ray or args.ray_address:
        try:  # before any work: a missing Ray or an unreachable head is said at once
            ray_runtime.import_ray()
            if args.ray_address:
                ray_runtime.check_reachable(args.ray_address)
        except ray_runtime.RayUnavailable as error:
            print(f"eval: {error}", file=sys.stderr)
            return 2
    checkpoint_dir = pathlib.Path(args.checkpoint_dir)
    results, runnable = {}, {}
    rows = list(dict.fromkeys(row_key(m, r) for r in args.rules for m in args.methods))
    for row in rows:
        method = method_of(row)
        checkpoint = checkpoint_for(method, checkpoint_dir, pathlib.Path(args.policy_checkpoint))
        if checkpoint is not None and not checkpoint.is_file():
            results[row] = {"missing": True, "checkpoint": shown_path(checkpoint)}
            print(f"eval: {label(row)}: no checkpoint at {checkpoint}: listed as not trained",
                  file=sys.stderr)
            continue
        make_agent(method, checkpoint)  # a checkpoint that does not load fails here, before any episode
        runnable[row] = str(checkpoint.resolve()) if checkpoint else ""  # workers need not share our cwd
        results[row] = {"checkpoint": shown_path(checkpoint) if checkpoint else "",
                        "sha256": file_digest(checkpoint) if checkpoint else "", "scenarios": {},
                        "episodes": []}
    started = time.perf_counter()
    groups = list(dict.fromkeys(args.palette_groups))
    counts = {"truth": ["truth"], "perception": ["perception"], "both": ["truth", "perception"]}[args.count]
    scene_set = (args.scene_set,) if args.scene_set else ()  # the paper's scenes: tasks as before scene sets
    tasks = [(row, checkpoint, scenario, args.seed_base + k, args.threads, args.device, "default", "", count,
              *scene_set)
             for count, n in [(c, args.episodes) for c in counts] + [("clean", args.clean_scenes)]
             for scenario in args.scenarios for row, checkpoint in runnable.items() for k in range(n)]
    group_counts = counts + (["clean"] if args.count != "truth" else [])  # a group's clean scenes as many
    tasks += [(row, checkpoint, scenario, args.seed_base + k, args.threads, args.device, group,
               generalisation.palette_for(group, k + args.group_palette_offset), count, *scene_set)
              for group in groups if group != "default" for count in group_counts
              for scenario in args.scenarios for row, checkpoint in runnable.items()
              for k in range(args.group_episodes)]
    journal = pathlib.Path(args.journal or pathlib.Path(args.json).with_suffix(".partial.jsonl"))
    if args.no_resume:
        journal.unlink(missing_ok=True)
    digests = {checkpoint: results[row]["sha256"] for row, checkpoint in runnable.items()}
    try:
        episodes = run_episodes(tasks, digests, journal, args)
    except ray_runtime.RayUnavailable as error:
        print(f"eval: {error}", file=sys.stderr)
        return 2
    episodes_seconds = time.perf_counter() - started
    episodes.sort(key=lambda e: (generalisation.GROUPS.index(e["group"]), args.scenarios.index(e["scenario"]),
                                 e["seed"]))
    by_perception = [e for e in episodes if e.get("counted_by", "truth") != "truth"]
    episodes = [e for e in episodes if e.get("counted_by", "truth") == "truth"]
    for row in runnable:
        results[row]["groups"] = {}
        for scenario in args.scenarios:
            mine = [e for e in episodes if e["row"] == row and e["scenario"] == scenario]
            results[row]["scenarios"][scenario] = aggregate([e for e in mine if e["group"] == "default"])
            for group in groups:
                results[row]["groups"].setdefault(group, {})[scenario] = aggregate(
                    [e for e in mine if e["group"] == group])
            results[row]["episodes"] += mine
        for group in dict.fromkeys(("default", *groups)):  # the main table's episodes are the default's
            counted = [e for e in by_perception if e["row"] == row and e["group"] == group]
            if not counted:
                continue
            figures = perception_figures.by_scenario(counted, args.scenarios)
            if group == "default":
                results[row]["by_perception"] = figures
            else:
                results[row].setdefault("by_perception_groups", {})[group] = figures
    perception_started = time.perf_counter()
    from ur5_driver_sim.core.world import CellWorld

    world = CellWorld(mode="floating")
    total = len(groups) * len(args.scenarios) * args.perception_scenes * 2
    with tqdm(total=total, desc="perception", unit="scene", disable=args.no_progress,
              dynamic_ncols=True) as bar:
        seen = generalisation.perception(world, groups, args.scenarios, args.perception_scenes,
                                         args.seed_base, progress=lambda: bar.update(1))
    pictures = pathlib.Path(args.generalisation_scenes)
    generalisation.scene_pictures(world, groups, args.seed_base, pictures)
    world.close()
    results["_generalisation"] = {
        "groups": groups, "palettes": {g: generalisation.group_palettes(g) for g in groups},
        "perception": seen, "scenes": args.perception_scenes,
        "episodes": {"default": args.episodes, "other": args.group_episodes},
        "seconds": {"perception": time.perf_counter() - perception_started, "episodes": episodes_seconds}}
    results["_meta"] = {"episodes": args.episodes, "seed_base": args.seed_base, "scenarios": args.scenarios,
                        "methods": args.methods, "rules": args.rules, "rows": rows,
                        "seconds": episodes_seconds,
                        "date": time.strftime("%Y-%m-%d"), "torch_threads": args.threads, "jobs": args.jobs,
                        "ray": args.ray_address or ("local" if args.ray else ""), "count": args.count,
                        "clean_scenes": args.clean_scenes, "scene_set": args.scene_set or "paper",
                        "split": args.split}
    arguments = argv if argv is not None else sys.argv[1:]
    command = "python -m impurity_learning.eval_cli " + " ".join(arguments)
    markdown, chart, raw = pathlib.Path(args.markdown), pathlib.Path(args.chart), pathlib.Path(args.json)
    for path in (markdown, chart, raw):
        path.parent.mkdir(parents=True, exist_ok=True)
    raw.write_text(json.dumps(results, indent=1, default=float) + "\n")
    plot_results(results, rows, args.scenarios, chart)
    write_markdown(results, rows, args.scenarios, markdown, chart, command.strip())
    if by_perception:
        section = perception_figures.perception_section(results, rows, args.scenarios, label,
                                                        generalisation.GROUP_LABELS)
        with open(markdown, "a") as out:
            out.write(f"\n{section}\n")
    gen_path, gen_chart = pathlib.Path(args.generalisation), pathlib.Path(args.generalisation_chart)
    generalisation.plot(results, rows, args.scenarios, groups, label, gen_chart)
    generalisation.write_markdown(results, rows, args.scenarios, groups, label, gen_path, gen_chart, pictures,
                                  command.strip())
    journal.unlink(missing_ok=True)  # every record is in the results now
    table = results_table(results, rows, args.scenarios)
    block = readme_table(results, rows, args.scenarios)
    if (args.count != "perception" and not args.scene_set and args.split == "evaluation"
            and update_readme(pathlib.Path(args.readme), block, markdown)):
        print(f"eval: updated the results block of {args.readme}", file=sys.stderr)
    print(table)
    print(generalisation.table(results, rows, args.scenarios, groups, label))
    if by_perception:
        print(perception_figures.perception_section(results, rows, args.scenarios, label,
                                                    generalisation.GROUP_LABELS))
    gen = results["_generalisation"]["seconds"]
    print(f"eval: wrote {markdown}, {chart}, {raw}, {gen_path}, {gen_chart}, {pictures}; episodes "
          f"{gen['episodes']:.0f} s, perception {gen['perception']:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
