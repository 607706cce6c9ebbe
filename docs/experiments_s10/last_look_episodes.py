"""Tenth session, tuning data only: truth-counted episodes with and without attention's verifier last look.

Counted by truth, an episode ends at the first view in which attention answers NONE, and a last look only
changes what attention answers there (no heap left, no region reaching the verifier's threshold). So an
episode with the last look runs exactly as without it up to the view where the one without it ended by
"no_target_or_cluster_left"; only those episodes are run again with it. Episodes without it come from
final_views.py's files (fresh tuning palettes, seeds 71000+) or are run here (`--palette blocks`).

    python docs/experiments_s10/last_look_episodes.py fresh --last-look 0.35     # the changed episodes only
    python docs/experiments_s10/last_look_episodes.py default --last-look 0.35   # blocks, 20 per scenario
"""
import argparse
import dataclasses
import json
import pathlib

import numpy as np

from impurity_attention.core.attention import AttentionParams
from impurity_learning.agents import make_agent
from impurity_learning.evaluate import SimCell
from impurity_policy.core import picking
from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
from impurity_policy.core.episode import TERMINATION_NOTHING_LEFT, EpisodeRequest
from ur5_driver_sim.core.world import CellWorld

OUT = pathlib.Path("runs/s10")
SCENARIOS = ("random", "challenging", "invisible")
DEFAULT_SEED_BASE = 72000


def run(world, agent, palette, scenario, seed, last_look):
    params = dataclasses.replace(AttentionParams(), verifier_last_look=last_look)
    cell = SimCell(world, agent, attention_params=params)
    s = picking.run_episode(cell, EpisodeRequest(scenario, seed=seed, palette=palette), f"{scenario}-{seed}",
                            on_error=lambda e: (_ for _ in ()).throw(e))
    return {"palette": palette, "scenario": scenario, "seed": seed, "last_look": last_look,
            "termination": s["termination_reason"], "completed": s["completed"], "picked": s["targets_picked"],
            "total": s["targets_total"], "attempts": s["grasp_attempts"], "actions": s["actions"]}


def figures(rows):
    out = []
    for scenario in SCENARIOS:
        sub = [r for r in rows if r["scenario"] == scenario]
        attempts = sum(r["attempts"] for r in sub)
        out.append((scenario, 100 * sum(r["picked"] for r in sub) / max(attempts, 1),
                    100 * np.mean([r["completed"] for r in sub]), len(sub)))
    return out


def show(name, rows):
    f = figures(rows)
    print(f"  {name:24s} grasp success " + " / ".join(f"{g:.1f}" for _, g, _, _ in f)
          + f" (mean {np.mean([g for _, g, _, _ in f]):.1f}); completion "
          + " / ".join(f"{c:.1f}" for _, _, c, _ in f) + f" (mean {np.mean([c for _, _, c, _ in f]):.1f}); "
          f"episodes {sum(n for *_, n in f)}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("which", choices=("fresh", "default"))
    ap.add_argument("--last-look", type=float, required=True)
    a = ap.parse_args()
    world = CellWorld(mode="floating")
    agent = make_agent("ours", SHIPPED_CHECKPOINT, "cell")
    if a.which == "fresh":  # final_views' episodes that ended by NONE, both ways (it kept no grasp counts)
        base = [json.loads(line) for p in sorted(OUT.glob("final_views_*.jsonl")) for line in p.read_text().splitlines()]
        rows = [run(world, agent, r["palette"], r["scenario"], r["seed"], 0.0) for r in base
                if r["termination"] == TERMINATION_NOTHING_LEFT]
        print(f"of {len(base)} episodes, {len(rows)} ended by NONE; they alone change with a last look")
        return write(rows, a, world, agent, "fresh")
    rows = []
    for k in range(20):
        for scenario in SCENARIOS:
            rows.append(run(world, agent, "", scenario, DEFAULT_SEED_BASE + k, 0.0))
    write(rows, a, world, agent, "default")


def write(rows, a, world, agent, name):
    looked = []
    for r in rows:
        if r["termination"] == TERMINATION_NOTHING_LEFT:
            looked.append(run(world, agent, r["palette"], r["scenario"], r["seed"], a.last_look))
        else:
            looked.append(dict(r, last_look=a.last_look))
    (OUT / f"last_look_{name}_{a.last_look:g}.jsonl").write_text(
        "".join(json.dumps(r) + "\n" for r in rows + looked))
    print(f"{name}: {sum(r['termination'] == TERMINATION_NOTHING_LEFT for r in rows)} episodes ended by NONE "
          f"without the last look, run again with it")
    show("without", rows)
    show(f"last look {a.last_look:g}", looked)


if __name__ == "__main__":
    main()
