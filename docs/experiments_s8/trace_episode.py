"""Eighth session, tuning seeds only: one fast-sim episode step by step (attention's mode and reason, the
action, its outcome, targets left / out of the workspace), under either attention decision.

    python docs/experiments_s8/trace_episode.py invisible 70016 [--palette blocks] [--decision rule]
"""
import argparse, dataclasses, pathlib
from impurity_attention.core.attention import AttentionParams
from impurity_learning.agents import make_agent
from impurity_learning.evaluate import SimCell
from impurity_policy.core import picking
from impurity_policy.core.episode import EpisodeRequest
from impurity_policy.policy_node import default_checkpoint
from ur5_driver_sim.core.world import CellWorld

ap = argparse.ArgumentParser()
ap.add_argument("scenario"); ap.add_argument("seed", type=int)
ap.add_argument("--palette", default="blocks"); ap.add_argument("--decision", default="verifier")
a = ap.parse_args()


class Traced(SimCell):
    def decide(self, view):
        att = self._sensed.attention
        action = super().decide(view)
        t = self._sensed.truth
        print(f"  view: {att.mode.name:16s} targets left {t.targets_remaining}, out {t.targets_out_of_workspace}"
              f" | {att.reason[:150]}")
        if action is not None:
            print(f"  -> {action.kind} at ({action.position[0]:.3f}, {action.position[1]:.3f}) q {action.q_value:.2f}")
        return action

    def execute(self, action):
        outcome = super().execute(action)
        print(f"     {'ok' if outcome.success else 'fail'} {'target grasped' if outcome.target_grasped else ''} "
              f"{outcome.message[:80]}")
        return outcome


world = CellWorld(mode="floating")
agent = make_agent("ours", pathlib.Path(default_checkpoint()), "cell")
cell = Traced(world, agent, dataclasses.replace(AttentionParams(), decision=a.decision))
request = EpisodeRequest(a.scenario, seed=a.seed, palette=a.palette)
summary = picking.run_episode(cell, request, f"{a.scenario}-{a.seed}", picking.EpisodeLimits())
print({k: summary[k] for k in ("targets_picked", "targets_total", "targets_outside", "actions",
                               "termination_reason")})
