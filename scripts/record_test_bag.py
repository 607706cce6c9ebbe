#!/usr/bin/env python3
"""Regenerate the regression bags: one short sim episode each, recorded with bag_recorder, trimmed to what
tests/graph/test_bag_replay_regression.py replays (a few MB each).

Steps: start the cell (impurity_bringup.launch_cell), start bag_recorder on the camera, decision and step
topics, run one episode (impurity_bringup.episode_client), stop the recorder and the cell, then keep only
  - the colour and depth frames whose decisions the episode executed (stamps of /episode/steps),
  - every camera_info, /attention/known_product, /policy/primitive and /episode/steps message (small),
and note in the bag's custom_data which policy weights decided (checkpoint SHA-256, or untrained + seed).

  source scripts/env.sh && python scripts/record_test_bag.py            # tests/data/episode_bag
  python scripts/record_test_bag.py --known-product                      # tests/data/known_product_bag
  python scripts/record_test_bag.py --untrained                          # seeded random weights
(`make test-bag` records both bags with the shipped checkpoint.)
"""

import argparse
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import yaml

from impurity_bags.bags import BagReader, BagWriter, cell_typestore, file_sha256
from impurity_bringup.cell_nodes import node_section
from impurity_common import names

ROOT = pathlib.Path(__file__).resolve().parents[1]
INSTALL = ROOT / "ros2_ws" / "install"
DEFAULT_OUTPUT = ROOT / "tests" / "data" / "episode_bag"
# an invisible scene's first view shows no target: the loop sends it to attention as the known product, and
# the second decision depends on it (the smallest invisible scene: 10 blocks for its two heaps)
KNOWN_PRODUCT_EPISODE = {"output": ROOT / "tests" / "data" / "known_product_bag", "scenario": "invisible",
                         "objects": 10, "max_actions": 2}
# as a bag spells them: the cell, recorded at the root namespace, under absolute names
COLOR, DEPTH, INFO = (names.absolute(topic)
                      for topic in (names.COLOR_TOPIC, names.DEPTH_TOPIC, names.CAMERA_INFO_TOPIC))
PRIMITIVE, STEPS = names.absolute(names.PRIMITIVE_TOPIC), names.absolute(names.EPISODE_STEPS_TOPIC)
# the known product is an input of attention as the camera is: an episode whose first view showed no target
# replays exactly only with it (tests/graph/test_bag_replay_regression.py plays it among the frames)
RECORDED_TOPICS = [COLOR, DEPTH, INFO, names.absolute(names.KNOWN_PRODUCT_TOPIC), PRIMITIVE, STEPS]
# custom_data keys read by the regression test
POLICY_KEY = "impurity.policy"  # "checkpoint" or "untrained"
CHECKPOINT_SHA_KEY = "impurity.checkpoint_sha256"
SEED_KEY = "impurity.untrained_seed"
EPISODE_KEY = "impurity.episode"


def stamp_ns(stamp) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def policy_overrides(untrained: bool, seed: int) -> tuple[dict, dict]:
    """(policy node parameters, bag notes) for the weights that will decide."""
    if untrained:
        return ({"allow_untrained": True, "seed": seed, "checkpoint": "/nonexistent/untrained.pt",
                 "rules_disabled": ["tried_actions"]},
                {POLICY_KEY: "untrained", SEED_KEY: str(seed)})
    from impurity_policy.policy_node import default_checkpoint

    checkpoint = pathlib.Path(default_checkpoint())
    if not checkpoint.is_file():
        raise SystemExit(f"record_test_bag: no checkpoint at {checkpoint}: train one (make train) "
                         "or record with --untrained")
    notes = {POLICY_KEY: "checkpoint", CHECKPOINT_SHA_KEY: file_sha256(checkpoint)}
    # Decisions must follow from the camera topics alone to replay exactly: no tried-action memory.
    return {"checkpoint": str(checkpoint), "rules_disabled": ["tried_actions"]}, notes


def write_config(base: pathlib.Path, policy_params: dict, path: pathlib.Path) -> pathlib.Path:
    config = yaml.safe_load(base.read_text()) or {}
    config.setdefault(node_section("policy"), {}).setdefault("ros__parameters", {}).update(policy_params)
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


def start(command: list[str], log: pathlib.Path) -> subprocess.Popen:
    return subprocess.Popen(command, stdout=open(log, "w"), stderr=subprocess.STDOUT, start_new_session=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))


def stop(process: subprocess.Popen, timeout: float = 20.0) -> int:
    for sig, wait in ((signal.SIGINT, timeout), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        if process.poll() is not None:
            break
        os.killpg(process.pid, sig)
        try:
            process.wait(wait)
        except subprocess.TimeoutExpired:
            continue
    return process.returncode


def wait_for_log(log: pathlib.Path, texts: list[str], timeout: float, processes) -> None:
    deadline = time.monotonic() + timeout
    while not all(t in log.read_text(errors="replace") for t in texts):
        dead = [p for p in processes if p.poll() is not None]
        if dead:
            raise RuntimeError(f"{dead[0].args[0]} exited ({dead[0].returncode}) before {texts} "
                               f"appeared in {log}")
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out after {timeout:.0f} s waiting for {texts} in {log}")
        time.sleep(0.2)


def trim(raw: pathlib.Path, output: pathlib.Path, notes: dict) -> dict:
    """Copy `raw` to `output` keeping the executed frames and the decisions; returns counts per topic."""
    typestore = cell_typestore()
    with BagReader(raw, typestore) as reader:
        executed = {stamp_ns(typestore.deserialize_cdr(m.data, m.msgtype).primitive.header.stamp)
                    for m in reader.messages([STEPS])}
        if not executed:
            raise RuntimeError(f"{raw} has no {STEPS} message: the episode executed nothing")
        counts: dict[str, int] = {}
        with BagWriter(output, typestore, custom_data=notes) as writer:
            for topic, info in reader.topics.items():
                writer.add_topic(topic, info.msgtype, info.qos)
            for message in reader.messages():
                if message.topic in (COLOR, DEPTH, INFO):
                    header = typestore.deserialize_cdr(message.data, message.msgtype).header
                    first_info = message.topic == INFO and INFO not in counts
                    if stamp_ns(header.stamp) not in executed and not first_info:
                        continue
                writer.write(message.topic, message.timestamp_ns, message.data)
                counts[message.topic] = counts.get(message.topic, 0) + 1
    return counts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=pathlib.Path, default=DEFAULT_OUTPUT)
    parser.add_argument("--config", type=pathlib.Path, default=ROOT / "bringup" / "config" / "cell.yaml")
    parser.add_argument("--scenario", default="random")
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--targets", type=int, default=1)
    parser.add_argument("--objects", type=int, default=6)
    parser.add_argument("--max-actions", type=int, default=3)
    parser.add_argument("--timeout", type=float, default=600.0, help="s for the episode")
    parser.add_argument("--untrained", action="store_true", help="decide with seeded random weights")
    parser.add_argument("--untrained-seed", type=int, default=0)
    parser.add_argument("--keep-raw", action="store_true", help="keep the untrimmed recording")
    parser.add_argument("--known-product", action="store_true",
                        help="the known-product bag: " + ", ".join(f"--{k.replace('_', '-')} {v}" for k, v in
                                                                   KNOWN_PRODUCT_EPISODE.items()))
    args = parser.parse_args(argv)
    if args.known_product:
        for key, value in KNOWN_PRODUCT_EPISODE.items():
            setattr(args, key, value)

    policy_params, notes = policy_overrides(args.untrained, args.untrained_seed)
    episode = ["--scenario", args.scenario, "--seed", str(args.seed), "--targets", str(args.targets),
               "--objects", str(args.objects), "--max-actions", str(args.max_actions)]
    notes[EPISODE_KEY] = " ".join(episode)
    # Our own DDS domain (unless one is set): a demo or test running beside us must not join the episode.
    os.environ.setdefault("ROS_DOMAIN_ID", str(200 + os.getpid() % 30))
    work = pathlib.Path(tempfile.mkdtemp(prefix="record_test_bag_"))
    config = write_config(args.config, policy_params, work / "cell.yaml")
    raw = work / "raw_bag"
    print(f"record_test_bag: working in {work}", flush=True)

    cell = start([sys.executable, "-m", "impurity_bringup.launch_cell", "--config", str(config),
                  "--log-dir", str(work / "logs"), "--record-dir", str(work / "records"), "--quiet"],
                 work / "launch_cell.log")
    recorder_log = work / "bag_recorder.log"
    recorder = start([str(INSTALL / "impurity_bags" / "lib" / "impurity_bags" / "bag_recorder"),
                      "--ros-args", "-p", f"output:={raw}", "-p", f"topics:=[{','.join(RECORDED_TOPICS)}]"],
                     recorder_log)
    recorder_code = None
    try:
        wait_for_log(recorder_log, [f"recording {t} (" for t in RECORDED_TOPICS], 180.0, [cell, recorder])
        print("record_test_bag: cell up, recorder subscribed; running the episode", flush=True)
        client = subprocess.run([sys.executable, "-m", "impurity_bringup.episode_client", *episode,
                                 "--timeout", str(args.timeout)], timeout=args.timeout + 60)
        if client.returncode != 0:
            raise RuntimeError(f"episode_client exited with {client.returncode} (logs in {work / 'logs'})")
        recorder_code = stop(recorder)
    except (RuntimeError, subprocess.TimeoutExpired) as error:
        print(f"record_test_bag: {error}", file=sys.stderr)
        return 1
    finally:  # also on Ctrl-C: never leave the cell running
        stop(recorder)
        stop(cell)
    if recorder_code != 0:
        print(f"record_test_bag: bag_recorder exited with {recorder_code} ({recorder_log})", file=sys.stderr)
        return 1

    trimmed = work / "episode_bag"
    counts = trim(raw, trimmed, notes)
    if args.output.exists():
        shutil.rmtree(args.output)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    shutil.move(str(trimmed), str(args.output))
    if not args.keep_raw:
        shutil.rmtree(raw)
    size = sum(f.stat().st_size for f in args.output.iterdir())
    print(f"record_test_bag: {args.output} ({size / 1e6:.1f} MB): "
          + ", ".join(f"{topic} {n}" for topic, n in counts.items()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
