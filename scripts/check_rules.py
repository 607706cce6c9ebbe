#!/usr/bin/env python3
"""Re-check the test-time rules' presets on the split that is kept for it: tuning seeds and tuning
palettes only (impurity_learning.splits), never the evaluation seeds or the held-out palettes.

Ours (the shipped network) runs the same fast-sim episodes with the `none` preset, the `cell` preset,
and `cell` without each of its rules in turn (leave one out). A rule earns its place in `cell` when
leaving it out costs grasp success, action efficiency or completion on these tuning episodes; the table
says so rule by rule. Episodes are counted by the simulator's truth, as `make eval` counts them.

    python scripts/check_rules.py --episodes 6 --jobs 2 --out runs/rules_check.md

Resumable: every finished episode is appended to --journal and a rerun skips what it holds.
"""

from __future__ import annotations

import argparse
import itertools
import json
import multiprocessing
import pathlib
import sys
import time

import numpy as np
from tqdm import tqdm

from impurity_learning import splits
from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
from impurity_policy.core.rules import RULE_ORDER

SCENARIOS = ("random", "challenging", "invisible")
SEED_BASE = 70_000  # tuning seeds (splits.TUNING_SEED_RANGE), apart from the verdict calibration's 50 000+
_WORKER: dict = {}


def variants() -> list:
    """(label, preset, rules left out): none, cell, and cell without each rule."""
    return [("none", "none", ()), ("cell", "cell", ())] + [(f"cell - {rule}", "cell", (rule,))
                                                           for rule in RULE_ORDER]


def run_one(task: tuple) -> dict:
    """One fast-sim episode of Ours with a variant's rules (in a pool worker, which keeps its world)."""
    import torch

    from impurity_learning.agents import NetworkAgent
    from impurity_learning.evaluate import run_episode
    from impurity_policy.core.episode import EpisodeRequest
    from impurity_policy.core.policy import Policy
    from impurity_policy.core.rules import RulePipeline
    from ur5_driver_sim.core.world import CellWorld

    label, preset, without, scenario, palette, seed, checkpoint = task
    if "world" not in _WORKER:
        torch.set_num_threads(1)
        _WORKER["world"] = CellWorld(mode="floating")
    agents = _WORKER.setdefault("agents", {})
    if label not in agents:
        rules = RulePipeline.preset(preset, without=without)
        agents[label] = NetworkAgent("ours", Policy.from_checkpoint(checkpoint, "cpu", rules=rules))
    started = time.monotonic()
    request = EpisodeRequest(scenario, seed=seed, palette=palette)
    metrics = run_episode(_WORKER["world"], agents[label], request)
    return {"variant": label, "scenario": scenario, "palette": palette, "seed": seed,
            "seconds": time.monotonic() - started, **{k: metrics[k] for k in (
                "grasp_success", "action_efficiency", "completed", "actions", "targets_picked",
                "targets_total", "false_rejects")}}


def tasks(episodes: int, checkpoint: str) -> list:
    palettes = itertools.cycle(splits.tuning_palettes(8))
    plan = [(scenario, next(palettes), SEED_BASE + 1000 * i + k) for i, scenario in enumerate(SCENARIOS)
            for k in range(episodes)]
    assert all(seed in splits.TUNING_SEED_RANGE for _, _, seed in plan)
    return [(label, preset, without, scenario, palette, seed, checkpoint)
            for label, preset, without in variants() for scenario, palette, seed in plan]


def key(task_or_record) -> tuple:
    if isinstance(task_or_record, dict):
        r = task_or_record
        return r["variant"], r["scenario"], r["palette"], r["seed"]
    return task_or_record[0], task_or_record[3], task_or_record[4], task_or_record[5]


def table(records: list) -> str:
    """Markdown: per variant and scenario, grasp success / action efficiency / completion (means over the
    episodes, in %), and the change against `cell` in points."""
    def mean(rows, name):
        return 100 * float(np.mean([float(r[name]) for r in rows])) if rows else float("nan")

    by = {}
    for r in records:
        by.setdefault(r["variant"], {}).setdefault(r["scenario"], []).append(r)
    lines = ["| rules | " + " | ".join(f"{s}: grasp / efficiency / completion" for s in SCENARIOS)
             + " | mean grasp / efficiency / completion (change against cell) |",
             "|---" * (len(SCENARIOS) + 2) + "|"]
    cell = {s: by.get("cell", {}).get(s, []) for s in SCENARIOS}
    cell_all = [r for rows in cell.values() for r in rows]
    for label, _, _ in variants():
        if label not in by:
            continue
        cells = []
        for s in SCENARIOS:
            rows = by[label].get(s, [])
            cells.append(f"{mean(rows, 'grasp_success'):.1f} / {mean(rows, 'action_efficiency'):.1f} / "
                         f"{mean(rows, 'completed'):.0f} (n={len(rows)})")
        rows = [r for rs in by[label].values() for r in rs]
        change = [mean(rows, m) - mean(cell_all, m)
                  for m in ("grasp_success", "action_efficiency", "completed")]
        overall = (f"{mean(rows, 'grasp_success'):.1f} / {mean(rows, 'action_efficiency'):.1f} / "
                   f"{mean(rows, 'completed'):.0f} ({change[0]:+.1f} / {change[1]:+.1f} / {change[2]:+.0f})")
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {overall} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--episodes", type=int, default=6, help="per variant and scenario")
    p.add_argument("--jobs", type=int, default=2, help="worker processes")
    p.add_argument("--checkpoint", default=str(SHIPPED_CHECKPOINT))
    p.add_argument("--journal", default="runs/rules_check.jsonl", help="finished episodes (resume)")
    p.add_argument("--out", default="runs/rules_check.md")
    args = p.parse_args(argv)
    journal = pathlib.Path(args.journal)
    journal.parent.mkdir(parents=True, exist_ok=True)
    done = {}
    if journal.exists():
        for line in journal.read_text().splitlines():
            try:
                record = json.loads(line)
            except json.JSONDecodeError:  # a line cut short by a killed run
                continue
            done[key(record)] = record
    todo = [t for t in tasks(args.episodes, args.checkpoint) if key(t) not in done]
    started = time.monotonic()
    with journal.open("a") as sink, multiprocessing.get_context("spawn").Pool(args.jobs) as pool:
        for record in tqdm(pool.imap_unordered(run_one, todo), total=len(todo), desc="rules check",
                           unit="episode"):
            sink.write(json.dumps(record) + "\n")
            sink.flush()
            done[key(record)] = record
    wanted = {key(t) for t in tasks(args.episodes, args.checkpoint)}
    records = [r for k, r in done.items() if k in wanted]
    text = (f"# Test-time rules re-checked on tuning seeds and palettes\n\n"
            f"`python scripts/check_rules.py --episodes {args.episodes} --jobs {args.jobs}`: Ours (the "
            f"shipped network), {args.episodes} episodes per variant and scenario, tuning seeds "
            f"{SEED_BASE}+ and the tuning palettes in turn ({', '.join(splits.tuning_palettes(8))}); "
            f"counted by the simulator's truth as `make eval` counts. {len(records)} episodes; this run "
            f"{time.monotonic() - started:.0f} s.\n\n{table(records)}\n")
    pathlib.Path(args.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
