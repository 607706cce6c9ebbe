"""The deployed graph against the fast sim: a few episodes per scenario through the full node graph
(camera/heightmap, attention, policy, episode node, UR5 arm driver), on the same held-out seeds as
`make eval`, side by side with the fast sim's records of those seeds (docs/results.json, row "ours@cell").

    python -m impurity_bringup.eval_graph --episodes 2   # after python -m impurity_learning.eval_cli

Writes docs/results_graph.md and the episode records in runs/eval_graph/, under the checkout
(checkout.root(): IMPURITY_CELL_ROOT, else the working directory).
"""

import argparse
import json
import pathlib
import sys
import time

import rclpy

from impurity_bringup import checkout
from impurity_bringup.episode_client import run_episode, running_cell
from impurity_common.enums import Scenario
from impurity_interfaces.action import RunEpisode
from impurity_learning.evaluate import EVAL_SEED_BASE

SCENARIOS = tuple(s.value for s in (Scenario.RANDOM, Scenario.CHALLENGING, Scenario.INVISIBLE))  # make eval's
FIELDS = ("targets_picked", "targets_total", "grasp_attempts", "pushes", "actions", "false_rejects")


def graph_record(result) -> dict:
    record = {field: int(getattr(result, field)) for field in FIELDS}
    record.update(grasp_success=float(result.grasp_success),
                  action_efficiency=float(result.action_efficiency),
                  termination_reason=result.termination_reason)
    return record


FAST_SIM_ROW = "ours@cell"  # make eval's row of the network and rules the graph runs (cell.yaml: rules cell)


def fast_sim_records(path: pathlib.Path, row: str = FAST_SIM_ROW) -> dict:
    """{(scenario, seed): episode} of `row` on the default palette in a make-eval results file (empty
    when absent)."""
    if not path.is_file():
        return {}
    results = json.loads(path.read_text())
    return {(e["scenario"], e["seed"]): e for e in results.get(row, {}).get("episodes", [])
            if e.get("group", "default") == "default"}


def cells(record: dict | None) -> list:
    if record is None:
        return ["–"] * 4
    return [f"{record['targets_picked']}/{record['targets_total']}",
            f"{record['grasp_attempts']} + {record['pushes']}",
            f"{100 * record['grasp_success']:.0f}", f"{100 * record['action_efficiency']:.0f}"]


def table(rows: list) -> str:
    lines = ["| Scenario | Seed | Graph: picked | Graph: grasps + pushes | Graph: grasp success % | "
             "Graph: efficiency % | Fast sim: picked | Fast sim: grasps + pushes | "
             "Fast sim: grasp success % | "
             "Fast sim: efficiency % |", "|---" * 10 + "|"]
    for scenario, seed, graph, fast in rows:
        lines.append(f"| {scenario} | {seed} | " + " | ".join(cells(graph) + cells(fast)) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=SCENARIOS)
    parser.add_argument("--episodes", type=int, default=2, help="per scenario")
    parser.add_argument("--seed-base", type=int, default=EVAL_SEED_BASE)
    root = checkout.root()
    parser.add_argument("--fast-sim", type=pathlib.Path, default=root / "docs" / "results.json")
    parser.add_argument("--out", type=pathlib.Path, default=root / "runs" / "eval_graph")
    parser.add_argument("--markdown", type=pathlib.Path, default=root / "docs" / "results_graph.md")
    parser.add_argument("--timeout", type=float, default=900.0, help="s per episode")
    args = parser.parse_args(argv)

    fast = fast_sim_records(args.fast_sim)
    rows, started = [], time.perf_counter()
    with running_cell(args.out) as launcher:
        rclpy.init()
        node = rclpy.create_node("eval_graph_client")
        try:
            for scenario in args.scenarios:
                for k in range(args.episodes):
                    seed = args.seed_base + k
                    print(f"eval_graph: {scenario} seed {seed}", flush=True)
                    result = run_episode(node, RunEpisode.Goal(scenario=scenario, seed=seed), args.timeout,
                                         printer=lambda line: print("  " + line, flush=True))
                    if launcher.poll() is not None or result is None:
                        print("eval_graph: the cell stopped or refused the episode; logs in "
                              f"{args.out / 'logs'}", file=sys.stderr)
                        return 1
                    rows.append((scenario, seed, graph_record(result), fast.get((scenario, seed))))
        except TimeoutError as error:
            print(f"eval_graph: {error}", file=sys.stderr)
            return 1
        finally:
            node.destroy_node()
            rclpy.try_shutdown()
    text = table(rows)
    matches = sum(1 for _, _, graph, fast_record in rows
                  if fast_record is not None and graph["targets_picked"] == fast_record["targets_picked"])
    compared = sum(1 for row in rows if row[3] is not None)
    args.markdown.write_text(
        "# The deployed graph against the fast sim\n\n"
        "Generated by `python -m impurity_bringup.eval_graph "
        f"{' '.join(argv if argv is not None else sys.argv[1:])}` "
        f"on {time.strftime('%Y-%m-%d')} in {time.perf_counter() - started:.0f} s: each episode through the "
        "full node graph with the UR5 arm driver (bringup/config/cell.yaml), on the held-out seeds of "
        "`make eval`; the fast-sim columns are that run's records of the same seeds "
        f"({args.fast_sim.name}).\n\n"
        f"{text}\n\nSame number of targets picked in {matches} of {compared} compared episodes. The arm and "
        "the floating gripper agree on single primitives (`python benchmarks/bench_sim.py --agreement 40`), "
        "but an episode is a chain of decisions: one different contact changes every later scene.\n")
    print(text)
    print(f"eval_graph: wrote {args.markdown}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
