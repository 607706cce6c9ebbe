"""Twenty-seventh session, tuning data only: why a challenging episode pushes in TARGET views. Replays
episodes of a push_out.py file (the same seed, palette, network, cell rules and known product as the shipped
arm) and prints, per decision, attention's mode, the primitive chosen, and after the rules the best push and
grasp Q values and how many grasp actions are left (finite Q) - 0 grasps left means the rules took every grasp
away, so the policy had to push.

    python docs/experiments_s27/target_pushes.py runs/s27/stall_shipped/challenging.jsonl 8375 8409
"""
import json
import sys

import numpy as np


def main(path, seeds):
    import torch

    from impurity_common.enums import AttentionMode
    from impurity_learning.agents import NetworkAgent
    from impurity_learning.evaluate import SimCell
    from impurity_policy.core import picking
    from impurity_policy.core.episode import EpisodeRequest
    from impurity_policy.core.policy import Policy
    from impurity_policy.core.rules import RulePipeline
    from impurity_policy.policy_node import default_checkpoint
    from ur5_driver_sim.core.world import CellWorld

    torch.set_num_threads(1)
    rows = {json.loads(line)["seed"]: json.loads(line) for line in open(path)}
    world = CellWorld(mode="floating")
    policy = Policy.from_checkpoint(default_checkpoint(), rules=RulePipeline.preset("cell"))
    decide = policy.decide
    log = []

    def logged(obs, *args, **kwargs):
        choice = decide(obs, *args, **kwargs)
        q = choice.q_maps
        push = q[:, 0][np.isfinite(q[:, 0]) & choice.masks[0]]
        grasp = q[:, 1][np.isfinite(q[:, 1]) & choice.masks[1]]
        log.append(f"{AttentionMode(int(obs.mode)).name[0]}:{'pg'[int(choice.decision.primitive)]} "
                   f"(push {push.max() if push.size else float('nan'):.2f}, grasp "
                   f"{grasp.max() if grasp.size else float('nan'):.2f}, grasps left {grasp.size})")
        return choice

    policy.decide = logged
    agent = NetworkAgent("ours", policy)
    for seed in seeds:
        row = rows[seed]
        log.clear()
        summary = picking.run_episode(SimCell(world, agent), EpisodeRequest(row["scenario"], seed=seed,
                                                                           palette=row["palette"]), str(seed))
        print(f"{row['scenario']} {seed} {row['palette']}: {summary['termination_reason']}, picked "
              f"{summary['targets_picked']}, attempts {summary['grasp_attempts']}, actions {summary['actions']} "
              f"(recorded {row['termination']}, {row['picked']}, {row['attempts']}, {row['actions']})")
        for i, line in enumerate(log, 1):
            print(f"   {i:2d} {line}")


if __name__ == "__main__":
    main(sys.argv[1], [int(s) for s in sys.argv[2:]])
