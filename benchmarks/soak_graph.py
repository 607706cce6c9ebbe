"""Soak: N picking episodes back to back through the node graph, each node's memory after each episode.

    python benchmarks/soak_graph.py --episodes 200          # make soak
    python benchmarks/soak_graph.py --episodes 20 --mode arm

The cell runs as `make demo` starts it (impurity_bringup.launch_cell, every node its own process), with the
simulator in floating-gripper mode by default (fast; the graph and its clients are the same). Episodes
cycle through random, challenging and invisible scenes on seeds 700000000 + k. After each episode the
resident memory (VmRSS) of every node process is printed. At the end: lost episodes (a node_lost or
error termination, a goal never answered, a timeout) and each node's memory growth after the warm-up
episodes, in MB and MB per episode, side by side. Nothing here is asserted: these are figures.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import tempfile
import time

import rclpy
import yaml

from impurity_bringup.cell_nodes import base_config, node_section
from impurity_bringup.episode_client import run_episode, running_cell
from impurity_interfaces.action import RunEpisode

SCENARIOS = ("random", "challenging", "invisible")
SEED_BASE = 700_000_000  # neither training (run seed x 1 000 003 + i) nor evaluation (900 000 000 + k)
NODE_NAMES = ("sim_cell", "heightmap_node", "attention_node", "policy_node", "episode_node",
              "cell_state_publisher", "decision_markers")


def children(pid: int) -> list[int]:
    """Every descendant process of `pid` (from /proc)."""
    parents = {}
    for entry in pathlib.Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            parents.setdefault(int(fields[1]), []).append(int(entry.name))
    found, queue = [], [pid]
    while queue:
        for child in parents.get(queue.pop(), []):
            found.append(child)
            queue.append(child)
    return found


def node_processes(launcher_pid: int) -> dict:
    """Node name -> pid, by the executable in each descendant's command line."""
    processes = {}
    for pid in children(launcher_pid):
        try:
            command = pathlib.Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        for name in NODE_NAMES:
            if f"/{name} " in command + " " and name not in processes:
                processes[name] = pid
    return processes


def rss_mb(pid: int) -> float:
    try:
        for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def soak_config(mode: str, out: pathlib.Path) -> pathlib.Path:
    config = yaml.safe_load(base_config().read_text())
    config[node_section("sim_cell")]["ros__parameters"]["mode"] = mode
    path = out / "soak_cell.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--mode", choices=("floating", "arm"), default="floating")
    parser.add_argument("--warmup", type=int, default=10, help="episodes before memory growth is counted")
    parser.add_argument("--timeout", type=float, default=600.0, help="s per episode")
    parser.add_argument("--out", type=pathlib.Path, default=None,
                        help="records and logs (default: a temp dir)")
    args = parser.parse_args(argv)
    out = args.out or pathlib.Path(tempfile.mkdtemp(prefix="soak_"))
    out.mkdir(parents=True, exist_ok=True)
    memory, reasons, lost = [], [], []
    started = time.perf_counter()
    with running_cell(out, soak_config(args.mode, out)) as launcher:
        rclpy.init()
        node = rclpy.create_node("soak_client")
        try:
            processes = {}
            for k in range(args.episodes):
                scenario, seed = SCENARIOS[k % len(SCENARIOS)], SEED_BASE + k
                try:
                    result = run_episode(node, RunEpisode.Goal(scenario=scenario, seed=seed), args.timeout,
                                         printer=lambda _line: None)
                    reason = "refused" if result is None else result.termination_reason
                except TimeoutError as error:
                    reason = f"timeout: {error}"
                if launcher.poll() is not None:
                    print(f"soak: the cell stopped after episode {k + 1}; logs in {out / 'logs'}",
                          file=sys.stderr)
                    return 1
                processes = processes or node_processes(launcher.pid)
                sample = {name: rss_mb(pid) for name, pid in processes.items()}
                memory.append(sample)
                reasons.append(reason)
                if reason.startswith(("node_lost", "error", "timeout", "refused")):
                    lost.append((k + 1, scenario, seed, reason))
                print(f"soak {k + 1:4d}/{args.episodes} {scenario:<11s} {reason:<28s} "
                      + " ".join(f"{name} {mb:6.1f} MB" for name, mb in sample.items()), flush=True)
        finally:
            node.destroy_node()
            rclpy.try_shutdown()
    seconds = time.perf_counter() - started
    print(f"\nsoak: {args.episodes} episodes ({args.mode} sim) in {seconds:.0f} s; lost {len(lost)}")
    for entry in lost:
        print(f"  lost: episode {entry[0]} {entry[1]} seed {entry[2]}: {entry[3]}")
    if len(memory) > args.warmup + 1:
        first, last = memory[args.warmup], memory[-1]
        span = len(memory) - 1 - args.warmup
        print(f"memory after episode {args.warmup + 1} -> after episode {len(memory)} ({span} episodes):")
        print(f"  {'node':<16s} {'start MB':>9s} {'end MB':>9s} {'growth MB':>10s} {'MB/episode':>11s}")
        for name in first:
            growth = last[name] - first[name]
            print(f"  {name:<16s} {first[name]:9.1f} {last[name]:9.1f} {growth:10.1f} {growth / span:11.3f}")
    print(f"records and node logs: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
