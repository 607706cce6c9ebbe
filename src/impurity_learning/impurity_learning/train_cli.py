"""`make train` (python -m impurity_learning.train_cli [options]): train the push-grasp policy in the
fast sim, resumable (same --run-dir), with a progress bar, CSV log and success plot. Then
`--export PATH` copies the trained network to the shipped checkpoint location.

On Ray (ray_train.py): `--actors N` rollout actors, each with its own simulated cell and a
copy of the network, feed this process's learner (replay, updates, log, checkpoints, plot, resume as
above); `--ray-address ADDR` runs the actors on a cluster. `--actors 1 --lockstep --broadcast-every 1`
is the one-process loop, row for row."""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT, read_checkpoint
from impurity_policy.core.rules import PRESETS

from .ray_train import DEFAULT_BROADCAST_EVERY
from .train import METHODS, PALETTE_SETS, TrainConfig, TrainingRun
from .trainer import Trainer, TrainerConfig

# The baselines' and ablations' networks (make train-baselines exports them here).
BASELINE_CHECKPOINT_DIR = pathlib.Path(__file__).resolve().parents[1] / "checkpoints"


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run-dir", default="runs/train", help="checkpoint, replay, log.csv, success.png")
    p.add_argument("--method", default="ours", choices=METHODS)
    p.add_argument("--iterations", type=int, default=10000, help="total iterations (resumed runs continue)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--num-targets", type=int, default=-1, help="-1: the random scenario's default")
    p.add_argument("--num-objects", type=int, default=-1)
    p.add_argument("--lr", type=float, default=TrainerConfig.learning_rate)
    p.add_argument("--replay-per-step", type=int, default=1)
    p.add_argument("--checkpoint-every", type=int, default=100)
    p.add_argument("--threads", type=int, default=2, help="torch CPU threads (1 on a shared machine)")
    p.add_argument("--device", default="cpu", help="cpu, cuda, cuda:N, or auto (CUDA when present)")
    p.add_argument("--max-hours", type=float, default=0.0,
                   help="stop and save after this much wall time (0: no limit); rerun to resume")
    p.add_argument("--rules", default="none", choices=sorted(PRESETS),
                   help="test-time rules preset applied while training too (none: the paper's argmax)")
    p.add_argument("--palettes", default="training", choices=PALETTE_SETS,
                   help="training: a random appearance per scene (splits.py); default: blue/red only")
    p.add_argument("--init-from", default="", metavar="CHECKPOINT",
                   help="start from this network checkpoint (weights only), e.g. the shipped one")
    p.add_argument("--epsilon-start", type=float, default=TrainerConfig.epsilon_start,
                   help="exploration at iteration 0 (decays 0.9998^t to 0.1); lower when fine-tuning")
    p.add_argument("--no-progress", action="store_true")
    ray = p.add_argument_group("Ray actor-learner (any of these runs the actors on Ray)")
    ray.add_argument("--actors", type=int, default=None,
                     help="rollout actors, each with a simulated cell (default with --ray/--ray-address: 2)")
    ray.add_argument("--ray", action="store_true", help="a local Ray runtime (--actors CPUs)")
    ray.add_argument("--ray-address", default=None, metavar="ADDR",
                     help="the actors run on the Ray cluster whose head is at ADDR (host:port, or auto)")
    ray.add_argument("--broadcast-every", type=int, default=DEFAULT_BROADCAST_EVERY, metavar="K",
                     help="learner updates between weight broadcasts to the actors")
    ray.add_argument("--lockstep", action="store_true",
                     help="an actor acts again only after the learner learnt from its last action")
    p.add_argument("--export", metavar="PATH", nargs="?", const=str(SHIPPED_CHECKPOINT),
                   help=f"after training, write the network-only checkpoint (default {SHIPPED_CHECKPOINT})")
    return p.parse_args(argv)


def export_network(checkpoint, path) -> pathlib.Path:
    """Network-only copy (no optimizer, no loop state): what the policy node loads; small."""
    data = read_checkpoint(checkpoint)
    from impurity_policy.core.network import NetworkConfig

    trainer = Trainer(NetworkConfig.from_dict(data["network_config"]))
    trainer.online.load_state_dict(data["online"])
    trainer.target.load_state_dict(data["online"])
    extra = {k: v for k, v in data.get("extra", {}).items() if k in ("method", "iteration", "config")}
    state = trainer.state_dict(extra)
    del state["optimizer"], state["target"]
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    import torch

    torch.save(state, path)
    return path


def main(argv=None) -> int:
    args = parse_args(argv)
    config = TrainConfig(run_dir=args.run_dir, method=args.method, iterations=args.iterations, seed=args.seed,
                         num_targets=args.num_targets, num_objects=args.num_objects,
                         replay_per_step=args.replay_per_step, checkpoint_every=args.checkpoint_every,
                         threads=args.threads, device=args.device, max_hours=args.max_hours,
                         progress=not args.no_progress,
                         rules=args.rules, palettes=args.palettes, init_from=args.init_from,
                         trainer=TrainerConfig(learning_rate=args.lr, epsilon_start=args.epsilon_start))
    if args.actors is not None or args.ray or args.ray_address:
        from .ray_runtime import RayUnavailable
        from .ray_train import ActorLearnerRun

        try:
            run = ActorLearnerRun(config, actors=args.actors or 2, broadcast_every=args.broadcast_every,
                                  lockstep=args.lockstep, address=args.ray_address)
        except RayUnavailable as error:
            print(f"train: {error}", file=sys.stderr)
            return 2
    else:
        run = TrainingRun(config)
    if run.resumed:
        print(f"resuming {config.run_dir} at iteration {run.iteration}", file=sys.stderr)
    try:
        result = run.run()
    finally:
        run.close()
    print(json.dumps(result, indent=2))
    if args.export:
        print(f"exported {export_network(run.checkpoint_path, args.export)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
