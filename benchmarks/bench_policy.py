"""Policy latency: all 32 Q maps (16 rotations x push/grasp) per decision, looped vs batched rotations,
a full decision (Q maps + masks + the cell's rules + pose), the rules alone, one DQN update, one TD target,
the Q-map picture.

    python benchmarks/bench_policy.py [--threads 2] [--repeats 30]

Budget: a decision's 32 maps <= 100 ms p50 on this 2-core machine. Printed, never asserted.
"""

import argparse
import os

import numpy as np
import torch
from timing import p50_p95, timed

from impurity_learning.replay import Transition
from impurity_learning.trainer import Trainer
from impurity_policy.core.decision import State
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig, QNetwork, network_inputs, parameter_count
from impurity_policy.core.policy import MODE_TARGET, Observation, Policy, q_maps_picture
from impurity_policy.core.rules import RulePipeline


def scene(size=112, seed=0):
    rng = np.random.default_rng(seed)
    height = np.zeros((size, size), np.float32)
    color = np.full((size, size, 3), 150, np.uint8)
    for _ in range(8):
        r, c = rng.integers(10, size - 10, 2)
        height[r - 8:r + 8, c - 8:c + 8] = rng.uniform(0.02, 0.05)
        color[r - 8:r + 8, c - 8:c + 8] = (40, 120, 200)
    mask = np.zeros((size, size), np.uint8)
    mask[48:64, 48:64] = 255
    return State(color, height, mask)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=30)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    print(f"torch {torch.__version__}, {args.threads} threads, load average {os.getloadavg()[0]:.2f}")

    sizes = (("ours 112^2", NetworkConfig()), ("no_tsd/vpg 224^2", NetworkConfig(crop_size=224)))
    for label, config in sizes:
        net = QNetwork(config).eval()
        state = scene(config.crop_size)
        inputs = network_inputs(state.color, state.height, state.mask)
        print(f"\n{label}: {parameter_count(net) / 1e6:.3f} M parameters")
        for chunk in (1, 4, 8, 16):
            with torch.no_grad():
                wall, _ = timed(lambda net=net, inputs=inputs, chunk=chunk: net.q_maps(inputs, chunk=chunk),
                                args.repeats if config.crop_size == 112 else 5)
            p50, p95 = p50_p95(wall)
            print(f"  32 Q maps, {chunk:2d} rotation(s) per pass: p50 {p50:7.1f} ms  p95 {p95:7.1f} ms")

    state = scene()
    policy = Policy(QNetwork().eval(), rules=RulePipeline.preset("cell"))  # as the cell runs it
    full_height = np.zeros((224, 224), np.float32)
    size = state.height.shape[0]
    full_height[50:50 + size, 50:50 + size] = state.height
    obs = Observation(MODE_TARGET, state.color, state.height, state.mask, (50, 50), full_height)
    p50, p95 = p50_p95(timed(lambda: policy.decide(obs), args.repeats)[0])
    print(f"\ndecision (Q maps + masks + rules 'cell' + argmax + pose): p50 {p50:.1f} ms  p95 {p95:.1f} ms")
    choice = policy.decide(obs)
    q, masks = policy.q_maps(obs), policy.masks(obs)
    wall, _ = timed(lambda: policy.rules.apply(q, obs, masks, policy.pose_rules, obs.grid), args.repeats)
    p50, _ = p50_p95(wall)
    print(f"rules 'cell' alone ({len(policy.rules.names)} rules: grasp clearance, target mask, ...): "
          f"p50 {p50:.1f} ms")
    wall, _ = timed(lambda: q_maps_picture(choice.q_maps, choice.masks, choice.decision), args.repeats)
    p50, _ = p50_p95(wall)
    print(f"Q-map debug picture: p50 {p50:.1f} ms")

    trainer = Trainer(seed=0)
    push = Transition(state, PUSH, 3, (56, 60), 0.5, state, (PUSH, GRASP))
    grasp = Transition(state, GRASP, 5, (56, 56), 1.0, None)
    p50, _ = p50_p95(timed(lambda: trainer.target_value(push.reward, push.next_state), args.repeats)[0])
    print(f"TD target (target network, 32 maps): p50 {p50:.1f} ms")
    p50, _ = p50_p95(timed(lambda: trainer.update(push, label=0.5), args.repeats)[0])
    print(f"DQN update, push (1 rotation fwd+bwd): p50 {p50:.1f} ms")
    p50, _ = p50_p95(timed(lambda: trainer.update(grasp, label=1.0), args.repeats)[0])
    print(f"DQN update, grasp (+ opposite rotation): p50 {p50:.1f} ms")


if __name__ == "__main__":
    main()
