#!/usr/bin/env python3
"""Simulated cell speed on this machine: scene generation per scenario, camera render, primitives per
second in the floating-gripper (training) and arm (driver) modes; optionally the arm/floating outcome
agreement and one camera picture per scenario. Printed, never asserted.

    python benchmarks/bench_sim.py                    # timings
    python benchmarks/bench_sim.py --agreement 40     # + arm vs floating outcome agreement over 40 seeds
    python benchmarks/bench_sim.py --oracle 50        # + oracle grasp rate on isolated blocks, both modes
    python benchmarks/bench_sim.py --images docs/images --only-images
"""

import argparse
import math
import os
import pathlib
import time

import numpy as np

from ur5_driver_sim.core.world import CellWorld, yaw_of_quaternion

SCENARIOS = ("random", "challenging", "invisible")


def scene_generation(world: CellWorld, seeds: int) -> None:
    for scenario in SCENARIOS:
        times, attempts = [], []
        for seed in range(seeds):
            start = time.perf_counter()
            info = world.reset_scene(scenario, seed=seed)
            times.append(time.perf_counter() - start)
            attempts.append(info.attempts)
        t = np.array(times) * 1000
        print(f"scene {scenario:<12s} 2 targets + 20 blocks: mean {t.mean():6.0f} ms  "
              f"p50 {np.median(t):6.0f} ms  max {t.max():6.0f} ms  attempts mean {np.mean(attempts):.2f} "
              f"(n={seeds})")


def render_time(world: CellWorld, repeats: int = 10) -> None:
    world.reset_scene("random", seed=0)
    world.render()
    start = time.perf_counter()
    for _ in range(repeats):
        world.render()
    print(f"render 640x480 RGB-D + segmentation: {(time.perf_counter() - start) / repeats * 1000:.0f} ms")


def clutter_primitive(world: CellWorld, rng: np.random.Generator, index: int):
    """Alternate grasps and pushes aimed at random blocks of the scene (what a learner does)."""
    poses = world.poses()
    if not poses:
        return None
    (x, y, z), quat = poses[sorted(poses)[rng.integers(len(poses))]]
    if index % 2 == 0:
        return "grasp", x, y, max(z - 0.015, 0.0), yaw_of_quaternion(quat) + rng.choice([0.0, math.pi / 2])
    direction = rng.uniform(0, 2 * math.pi)
    return "push", x - 0.05 * math.cos(direction), y - 0.05 * math.sin(direction), 0.01, direction


def actions_per_second(mode: str, actions: int, seed: int) -> None:
    world = CellWorld(mode=mode)
    rng = np.random.default_rng(seed)
    world.reset_scene("random", seed=seed)
    done, grasped, elapsed, cpu = 0, 0, 0.0, 0.0
    while done < actions:
        primitive = clutter_primitive(world, rng, done)
        if primitive is None or len(world.poses()) < 12:
            world.reset_scene("random", seed=seed + done + 1)  # not timed: keep the clutter dense
            continue
        start, start_cpu = time.perf_counter(), time.process_time()
        outcome = world.execute(*primitive)
        elapsed += time.perf_counter() - start
        cpu += time.process_time() - start_cpu
        grasped += primitive[0] == "grasp" and outcome.success
        done += 1
    world.close()
    print(f"mode {mode:<9s} {actions} primitives in clutter: {actions / elapsed:5.2f} actions/s wall "
          f"({elapsed / actions * 1000:.0f} ms each), {actions / cpu:5.2f} per CPU-second; "
          f"{grasped}/{(actions + 1) // 2} grasps lifted something")


def agreement(seeds: int, scenario: str = "random") -> None:
    """Same scene, same primitive in both modes; outcome classes as in
    tests/unit/ur5_driver_sim/test_sim_arm.py."""
    worlds = {mode: CellWorld(mode=mode) for mode in ("floating", "arm")}
    same = strict = 0
    for seed in range(seeds):
        results = {}
        for mode, world in worlds.items():
            world.reset_scene(scenario, seed=seed, num_targets=1, num_objects=7)
            rng = np.random.default_rng(1000 + seed)
            primitive = clutter_primitive(world, rng, seed)
            before = world.poses()
            outcome = world.execute(*primitive)
            after = world.poses()
            moves = {b: math.dist(before[b][0][:2], after[b][0][:2]) for b in before if b in after}
            top = max(moves, key=moves.get)
            if primitive[0] == "grasp":
                results[mode] = (outcome.success,), (outcome.success, outcome.object_id)
            else:
                cls = CellWorld.displacement_class(moves[top])
                results[mode] = (cls,), (cls, top)
        same += results["floating"][0] == results["arm"][0]
        strict += results["floating"][1] == results["arm"][1]
    print(f"mode agreement over {seeds} seeded primitives ({scenario}, 8 blocks): {same}/{seeds} = "
          f"{100 * same / seeds:.1f} % "
          f"(grasped or not / displacement class); {100 * strict / seeds:.1f} % also the same block")


def oracle_grasps(mode: str, seeds: int) -> None:
    """The oracle: one block alone, true centre, closing across its short horizontal axis (a prism
    across its flat ends), the same cases as tests/unit/ur5_driver_sim/test_sim_*.py."""
    import json
    import tempfile

    from ur5_driver_sim.core.shapes import SHAPES, random_dims

    world = CellWorld(mode=mode)
    successes = 0
    with tempfile.TemporaryDirectory() as directory:
        for seed in range(seeds):
            rng = np.random.default_rng(seed)
            shape = SHAPES[seed % len(SHAPES)]
            dims = random_dims(shape, rng)
            x, y, yaw = rng.uniform(0.38, 0.62), rng.uniform(-0.12, 0.12), rng.uniform(0, math.pi)
            path = pathlib.Path(directory) / "block.json"
            path.write_text(json.dumps([dict(shape=shape, dims=dims, position=[x, y, dims[2] / 2 + 0.001],
                                             yaw=yaw, is_target=True)]))
            world.reset_scene("file", scene_file=str(path))
            (_, (pos, quat)), = world.poses().items()
            across_y = dims[1] < dims[0] or shape == "prism"
            grasp_yaw = yaw_of_quaternion(quat) + (math.pi / 2 if across_y else 0.0)
            outcome = world.grasp(pos[0], pos[1], max(pos[2] - 0.015, 0.0), grasp_yaw)
            successes += outcome.success and outcome.target_grasped
    world.close()
    rate = 100 * successes / seeds
    print(f"oracle grasp, isolated block, mode {mode:<9s}: {successes}/{seeds} = {rate:.0f} %")


def save_images(world: CellWorld, directory: pathlib.Path, seed: int) -> None:
    import cv2

    directory.mkdir(parents=True, exist_ok=True)
    for scenario in SCENARIOS:
        world.reset_scene(scenario, seed=seed)
        frame = world.render()
        path = directory / f"scene_{scenario}.png"
        cv2.imwrite(str(path), cv2.cvtColor(frame.color, cv2.COLOR_RGB2BGR))
        print(f"wrote {path} ({scenario}, seed {seed}, visible target pixels "
              f"{world.ground_truth(frame).visible_target_pixels})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene-seeds", type=int, default=10)
    parser.add_argument("--floating-actions", type=int, default=40)
    parser.add_argument("--arm-actions", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--agreement", type=int, default=0, metavar="N", help="also measure mode agreement")
    parser.add_argument("--agreement-scenario", default="random", choices=SCENARIOS)
    parser.add_argument("--oracle", type=int, default=0, metavar="N", help="also oracle grasps over N seeds")
    parser.add_argument("--images", type=pathlib.Path, help="write one camera picture per scenario here")
    parser.add_argument("--only-images", action="store_true")
    args = parser.parse_args()

    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (wall figures suffer under load)")
    world = CellWorld(mode="floating")
    if args.images is not None:
        save_images(world, args.images, args.seed)
        if args.only_images:
            return
    scene_generation(world, args.scene_seeds)
    render_time(world)
    world.close()
    actions_per_second("floating", args.floating_actions, args.seed)
    actions_per_second("arm", args.arm_actions, args.seed)
    if args.oracle:
        for mode in ("floating", "arm"):
            oracle_grasps(mode, args.oracle)
    if args.agreement:
        agreement(args.agreement, args.agreement_scenario)


if __name__ == "__main__":
    main()
