"""Nineteenth session, tuning data only: why the cell pushes while a target is in view.

Replays truth-counted episodes of the shipped network under `cell` (push_out.py's tasks: the same seed,
palette and rules, so the same actions) and records, for every decision, attention's mode, the primitive
chosen, and in TARGET mode which rule left no grasp (the first rule in RULE_ORDER after which no valid grasp
had a finite Q value), or "q" when grasps were left and the network's push Q was higher. `report` prints each
episode as a line: "." a decision in another mode, "G" a grasp in TARGET mode, a push in TARGET mode as the
rule that left no grasp (o grasp_on_target, c grasp_at_target_core, f finger_clearance, t tried_actions, w
grasp_where_target_on_top) or q.

    python docs/experiments_s19/target_pushes.py run docs/experiments_s18/episodes/fresh_shipped.jsonl \
        runs/s19/target_pushes_fresh.jsonl [--only-incomplete]
    python docs/experiments_s19/target_pushes.py report runs/s19/target_pushes_fresh.jsonl
"""
import argparse
import collections
import json
import pathlib
import sys
from concurrent.futures import ProcessPoolExecutor

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "experiments_s14"))
import push_out  # noqa: E402

TRACE = []


def traced_apply(self, q, obs, valid, pose_rules, grid):
    """RulePipeline.apply, also noting the first rule after which no valid grasp kept a finite Q value: the
    pipeline's own apply on its first i rules, for i = 1, 2, ... (the same rule objects, so tried_actions keeps
    its memory; its keeps() only drops entries it would drop anyway)."""
    import copy

    import numpy as np

    from impurity_policy.core.network import GRASP
    finite = np.isfinite(q[:, GRASP]) & valid[GRASP]
    emptied = None
    if finite.any():
        partial = copy.copy(self)
        for count, rule in enumerate(self.rules, start=1):
            partial.rules = self.rules[:count]
            left = ORIGINAL[0](partial, q, obs, valid, pose_rules, grid)[:, GRASP]
            if not (np.isfinite(left) & valid[GRASP]).any():
                emptied = rule.name
                break
    TRACE.append({"mode": int(obs.mode), "grasps_valid": bool(finite.any()), "emptied": emptied})
    return ORIGINAL[0](self, q, obs, valid, pose_rules, grid)


def traced_decide(self, obs, *args, **kwargs):
    """Policy.decide, also noting the primitive chosen (0 push, 1 grasp) on the decision's trace entry."""
    choice = ORIGINAL[1](self, obs, *args, **kwargs)
    TRACE[-1]["primitive"] = int(choice.decision.primitive)
    return choice


ORIGINAL = []  # RulePipeline.apply, Policy.decide as they were


def replay(task):
    from impurity_policy.core.policy import Policy
    from impurity_policy.core.rules import RulePipeline
    if not ORIGINAL:
        ORIGINAL.extend([RulePipeline.apply, Policy.decide])
        RulePipeline.apply, Policy.decide = traced_apply, traced_decide
    TRACE.clear()
    push_out.run_one(task)  # rebuilds nothing it has: the worker keeps world and agent
    return list(TRACE)


def run(args) -> None:
    rows = [json.loads(line) for line in open(args.episodes)]
    if args.only_incomplete:
        rows = [r for r in rows if not r["completed"]]
    tasks = [(r["scenario"], r["seed"], r["palette"], r["params"]) for r in rows]
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    from tqdm import tqdm
    with ProcessPoolExecutor(args.jobs) as pool, open(out, "w") as f:
        for row, trace in tqdm(zip(rows, pool.map(replay, tasks), strict=True), total=len(rows)):
            f.write(json.dumps({**{k: row[k] for k in ("scenario", "seed", "palette", "termination",
                                                       "completed", "picked", "total", "actions")},
                                "trace": trace}) + "\n")
            f.flush()


def report(args) -> None:
    for path in args.files:
        rows = [json.loads(line) for line in open(path)]
        print(f"== {path}: {len(rows)} episodes")
        letter = {None: "q", "grasp_on_target": "o", "grasp_at_target_core": "c", "finger_clearance": "f",
                  "tried_actions": "t", "grasp_where_target_on_top": "w"}
        for r in rows:
            line = "".join("." if s["mode"] != 1 else letter.get(s["emptied"], "?") if s["primitive"] == 0
                           else "G" for s in r["trace"])
            print(f"    {r['scenario'][:4]} {r['seed']} {r['palette']}: {r['picked']}/{r['total']} {line}")
        for scenario in ("random", "challenging", "invisible"):
            chosen = [r for r in rows if r["scenario"] == scenario]
            why = collections.Counter(step["emptied"] or "q" for r in chosen for step in r["trace"]
                                      if step["mode"] == 1 and step["primitive"] == 0)
            target_views = sum(why.values())
            print(f"  {scenario}: {len(chosen)} episodes, {target_views} pushes in TARGET mode; "
                  f"no grasp left after: {dict(why.most_common())} (q: grasps left, the push's Q higher)")
            for r in chosen:
                run_ = longest = 0
                for step in r["trace"]:
                    run_ = run_ + 1 if step["mode"] == 1 and step["primitive"] == 0 else 0
                    longest = max(longest, run_)
                if longest >= args.run:
                    rules = collections.Counter(s["emptied"] or "q" for s in r["trace"]
                                                if s["mode"] == 1 and s["primitive"] == 0)
                    print(f"    {r['seed']} {r['palette']}: {r['termination']}, picked {r['picked']}/{r['total']} "
                          f"in {r['actions']}; {longest} TARGET-mode pushes in a row: {dict(rules)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("episodes")
    r.add_argument("out")
    r.add_argument("--only-incomplete", action="store_true")
    r.add_argument("--jobs", type=int, default=1)
    s = sub.add_parser("report")
    s.add_argument("files", nargs="+")
    s.add_argument("--run", type=int, default=5, help="list episodes with this many such views in a row")
    args = parser.parse_args(argv)
    {"run": run, "report": report}[args.command](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
