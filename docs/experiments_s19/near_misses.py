"""Nineteenth session, tuning data only: grasps placed on a target that close on nothing.

About one grasp in ten in the random and challenging scenarios ends within 2 cm of a target's centre with
nothing lifted (docs/experiments_s18/episodes/*: "target_m" of the failed grasps). This replays such
episodes (push_out.py's tasks: the same seed, palette and rules, so the same actions) and records, for
every grasp, the simulator's message and the nearest target's shape, extents and pose: the grasp's closing
axis against the block's axes (degrees, 0 = closing across the block's x extent), how far the tip was
asked to go below the block's top, and what was lifted.

    python docs/experiments_s19/near_misses.py run docs/experiments_s18/episodes/fresh_shipped.jsonl \
        runs/s19/near_misses_fresh.jsonl --scenario random
    python docs/experiments_s19/near_misses.py report runs/s19/near_misses_fresh.jsonl
"""
import argparse
import collections
import json
import math
import pathlib
import sys
from concurrent.futures import ProcessPoolExecutor

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "experiments_s14"))
import push_out  # noqa: E402

LOG = []


def replay(task):
    import pybullet

    from ur5_driver_sim.core.world import CellWorld
    if not getattr(CellWorld, "_traced", False):
        original = CellWorld.grasp

        def grasp(self, x, y, z, yaw, phase=lambda name, progress: None):
            poses = self.poses()
            nearest, best = None, math.inf
            for body in [b for b, spec in self.specs.items() if spec.is_target]:
                (bx, by, bz), quat = poses[body]
                distance = math.hypot(bx - x, by - y)
                if distance < best:
                    nearest, best = body, distance
            record = {"x": x, "y": y, "z": z, "yaw": yaw, "target_m": best}
            if nearest is not None:
                spec = self.specs[nearest]
                (bx, by, bz), quat = poses[nearest]
                roll, pitch, body_yaw = pybullet.getEulerFromQuaternion(quat)
                # closing axis: the fingers close along yaw; angle to the block's x axis, folded to 0-90
                relative = math.degrees((yaw - body_yaw) % math.pi)
                record.update({"shape": spec.shape, "dims": [round(d, 3) for d in spec.dims],
                               "tilt_deg": round(math.degrees(math.hypot(roll, pitch)), 1),
                               "closing_vs_x_deg": round(min(relative, 180 - relative), 1),
                               "top_m": round(bz + spec.dims[2] / 2, 4), "centre_z": round(bz, 4)})
            outcome = original(self, x, y, z, yaw, phase)
            record.update({"message": outcome.message, "lifted": outcome.success,
                           "target": bool(outcome.target_grasped), "opening": outcome.gripper_opening})
            LOG.append(record)
            return outcome

        CellWorld.grasp = grasp
        CellWorld._traced = True
    LOG.clear()
    push_out.run_one(task)
    return list(LOG)


def run(args) -> None:
    rows = [json.loads(line) for line in open(args.episodes)]
    rows = [r for r in rows if r["scenario"] in args.scenario]
    tasks = [(r["scenario"], r["seed"], r["palette"], r["params"]) for r in rows]
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    from tqdm import tqdm
    with ProcessPoolExecutor(args.jobs) as pool, open(out, "w") as f:
        for row, log in tqdm(zip(rows, pool.map(replay, tasks), strict=True), total=len(rows)):
            f.write(json.dumps({**{k: row[k] for k in ("scenario", "seed", "palette", "completed", "picked",
                                                       "total")}, "grasps": log}) + "\n")
            f.flush()


def report(args) -> None:
    rows = [json.loads(line) for line in open(args.file)]
    grasps = [dict(g, scenario=r["scenario"], seed=r["seed"]) for r in rows for g in r["grasps"]]
    near = [g for g in grasps if g["target_m"] <= 0.02 and "shape" in g]
    print(f"{len(rows)} episodes, {len(grasps)} grasps, {len(near)} within 2 cm of a target's centre")
    for name, chosen in (("on target, lifted it", [g for g in near if g["target"]]),
                         ("on target, nothing / other lifted", [g for g in near if not g["target"]])):
        shapes = collections.Counter(g["shape"] for g in chosen)
        messages = collections.Counter(g["message"].split(" (")[0][:40] for g in chosen)
        print(f"== {name}: {len(chosen)}")
        print(f"   shapes {dict(shapes.most_common())}")
        print(f"   messages {dict(messages.most_common())}")
        for shape in sorted(shapes):
            sub = [g for g in chosen if g["shape"] == shape]
            angles = sorted(g["closing_vs_x_deg"] for g in sub)
            depth = sorted(round((g["top_m"] - g["z"]) * 1000) for g in sub)
            tilt = sorted(g["tilt_deg"] for g in sub)
            print(f"   {shape:14s} closing vs block x (deg) {angles}")
            print(f"   {'':14s} tip below the top (mm) {depth}")
            print(f"   {'':14s} tilt (deg) {tilt}")
    if args.list:
        for g in near:
            if not g["target"]:
                print(f"   {g['scenario'][:4]} {g['seed']} {g['shape']} {g['dims']} tilt {g['tilt_deg']} closing "
                      f"{g['closing_vs_x_deg']} top {g['top_m']} z {g['z']:.4f}: {g['message']}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("episodes")
    r.add_argument("out")
    r.add_argument("--scenario", nargs="+", default=["random", "challenging", "invisible"])
    r.add_argument("--jobs", type=int, default=1)
    s = sub.add_parser("report")
    s.add_argument("file")
    s.add_argument("--list", action="store_true")
    args = parser.parse_args(argv)
    {"run": run, "report": report}[args.command](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
