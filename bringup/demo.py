#!/usr/bin/env python3
"""`make demo`: start the cell's node graph, run one picking episode, print it, draw it, stop.

Writes runs/demo/<episode>/ (steps.jsonl, summary.json, episode.png) and node logs in runs/demo/logs/.
"""

import argparse
import pathlib
import shutil
import sys

import rclpy

from impurity_common.enums import EPISODE_SCENARIOS, Scenario
from impurity_interfaces.action import RunEpisode
from impurity_policy.core.episode import is_failure

BRINGUP = pathlib.Path(__file__).resolve().parent
ROOT = BRINGUP.parent
sys.path.insert(0, str(BRINGUP))
from episode_client import format_result, run_episode, running_cell  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=Scenario.CHALLENGING.value,
                        choices=[scenario.value for scenario in EPISODE_SCENARIOS])
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--targets", type=int, default=2)
    parser.add_argument("--objects", type=int, default=20)
    parser.add_argument("--timeout", type=float, default=900.0)
    parser.add_argument("--out", type=pathlib.Path, default=ROOT / "runs" / "demo")
    args = parser.parse_args(argv)

    with running_cell(args.out) as launcher:
        print(f"demo: cell starting (node logs in {args.out / 'logs'})", flush=True)
        code = run_demo_episode(args, launcher)
    print("demo: cell stopped", flush=True)
    return code


def run_demo_episode(args, launcher) -> int:
    rclpy.init()
    node = rclpy.create_node("demo_client")
    code = 1
    try:
        goal = RunEpisode.Goal(scenario=args.scenario, seed=args.seed, num_targets=args.targets,
                               num_objects=args.objects)
        print(f"demo: episode {args.scenario} seed {args.seed}, {args.targets} targets among "
              f"{args.objects} blocks", flush=True)
        result = run_episode(node, goal, args.timeout, printer=lambda line: print(line, flush=True))
        if launcher.poll() is not None:
            print(f"demo: the cell stopped (exit {launcher.returncode}); see {args.out / 'logs'}",
                  file=sys.stderr)
        elif result is None:
            print("demo: the episode goal was rejected", file=sys.stderr)
        else:
            print(format_result(result))
            record = pathlib.Path(result.record_path)
            picture = record / "episode.png"
            if picture.exists():
                shutil.copy(picture, args.out / "episode.png")
                shutil.copy(record / "steps.jsonl", args.out / "episode.jsonl")
                print(f"demo: picture {args.out / 'episode.png'}, record {args.out / 'episode.jsonl'}")
            code = 1 if is_failure(result.termination_reason) else 0
    except TimeoutError as error:
        print(f"demo: {error}", file=sys.stderr)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == "__main__":
    sys.exit(main())
