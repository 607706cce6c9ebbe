"""`make demo`: start the cell's node graph, run one picking episode, print it, draw it, stop.

    python -m impurity_bringup.demo [--scenario S] [--seed N] ...   (or the `demo` console script)

Writes runs/demo/<episode>/ (steps.jsonl, summary.json, episode.png) and node logs in runs/demo/logs/, under
the checkout (checkout.root(): IMPURITY_CELL_ROOT, else the working directory).
"""

import argparse
import dataclasses
import os
import pathlib
import shutil
import sys
import time

import rclpy
from rclpy.action import ActionClient

from impurity_bringup import checkout
from impurity_bringup.episode_client import format_result, run_episode, running_cell
from impurity_common.enums import EPISODE_SCENARIOS, Scenario
from impurity_common.names import RUN_EPISODE_ACTION, absolute
from impurity_interfaces.action import RunEpisode
from impurity_policy.core.episode import EpisodeRequest, describe_request, is_failure


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=Scenario.CHALLENGING.value,
                        choices=[scenario.value for scenario in EPISODE_SCENARIOS])
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--targets", type=int, default=2)
    parser.add_argument("--objects", type=int, default=20)
    parser.add_argument("--palette", default="", help="the scene's appearance (default: the blue blocks)")
    parser.add_argument("--timeout", type=float, default=900.0)
    parser.add_argument("--out", type=pathlib.Path, default=checkout.root() / "runs" / "demo")
    parser.add_argument("--probe", type=float, default=3.0,
                        help="s to look for another cell on this ROS domain first (0 = do not look)")
    args = parser.parse_args(argv)

    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    if args.probe > 0 and another_cell(args.probe):
        print(f"demo: another cell is running on ROS_DOMAIN_ID={domain} (its {absolute(RUN_EPISODE_ACTION)} "
              "answers): stop it, or run the demo on a domain of its own, e.g. ROS_DOMAIN_ID=42 make demo",
              file=sys.stderr)
        return 1
    with running_cell(args.out) as launcher:
        print(f"demo: cell starting on ROS_DOMAIN_ID={domain} (node logs in {args.out / 'logs'})",
              flush=True)
        code = run_demo_episode(args, launcher)
    print("demo: cell stopped", flush=True)
    return code


def another_cell(seconds: float) -> bool:
    """Whether an episode action server already answers on this ROS domain within `seconds` (discovery
    takes a moment): a second cell would share its topics, and its busy episode node would refuse the
    demo's goal."""
    rclpy.init()
    node = rclpy.create_node("demo_probe")
    client = ActionClient(node, RunEpisode, RUN_EPISODE_ACTION)
    try:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            if client.server_is_ready():
                return True
            rclpy.spin_once(node, timeout_sec=0.1)
        return False
    finally:
        client.destroy()
        node.destroy_node()
        rclpy.try_shutdown()


def run_demo_episode(args, launcher) -> int:
    rclpy.init()
    node = rclpy.create_node("demo_client")
    code = 1
    try:
        request = EpisodeRequest(scenario=args.scenario, seed=args.seed, num_targets=args.targets,
                                 num_objects=args.objects, palette=args.palette)
        goal = RunEpisode.Goal(**dataclasses.asdict(request))
        print(f"demo: episode {describe_request(request)}", flush=True)
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
