"""DQN for the push-grasp FCAVF (paper 5.2.1 and 6.2): target network, Huber loss at the executed pixel
only, gamma = 0.5, SGD (momentum 0.9, weight decay 2e-5), epsilon-greedy, checkpoints.

TD target: y = r + gamma * max_{a'} Q(s', a'; theta^-) over the primitives allowed in s' (pushes
only when no target is visible) and the valid pixels, with theta^- a copy of the online weights
refreshed every `target_sync_every` updates; y = r at the end of an episode. A grasp's label also
trains the opposite rotation (index + 8): closing the fingers across yaw or yaw + pi is the same grasp.

Learning rate: the paper's 1e-5 fine-tunes ImageNet-pretrained DenseNets; our towers start from
random weights and get ~10^4 updates in a 2.5 h budget, so we use VPG's 1e-4 (DESIGN.md reference
figures). TrainerConfig.learning_rate changes it; the value is stored in checkpoints.
"""

from __future__ import annotations

import copy
import pathlib
from dataclasses import asdict, dataclass

import numpy as np
import torch
import torch.nn.functional as F

from impurity_policy.core.checkpoint import CHECKPOINT_FORMAT_VERSION, read_checkpoint
from impurity_policy.core.decision import State, action_masks, best_action
from impurity_policy.core.network import GRASP, PUSH, NetworkConfig, QNetwork, network_inputs, resolve_device

from .replay import Transition


@dataclass(frozen=True)
class TrainerConfig:
    learning_rate: float = 1e-4
    momentum: float = 0.9
    weight_decay: float = 2e-5
    gamma: float = 0.5
    huber_delta: float = 1.0
    target_sync_every: int = 100  # updates between target-network refreshes
    epsilon_start: float = 0.5  # VPG: epsilon = max(0.5 * 0.9998^t, 0.1)
    epsilon_decay: float = 0.9998
    epsilon_min: float = 0.1
    grasp_trains_opposite: bool = True
    grasp_needs_object: bool = True  # mask grasps on empty table (domain knowledge, speeds learning)

    def epsilon(self, iteration: int) -> float:
        return max(self.epsilon_start * self.epsilon_decay ** iteration, self.epsilon_min)


@torch.no_grad()
def q_maps(net: QNetwork, state: State, device) -> np.ndarray:
    """All 32 Q maps (R, 2, S, S) of `net` for one state, in eval mode (the mode is restored): what the
    trainer's TD targets and the training loop's decisions (train.Rollout, also in a Ray actor) use."""
    was_training = net.training
    net.eval()
    q = net.q_maps(network_inputs(state.color, state.height, state.mask).to(device)).cpu().numpy()
    net.train(was_training)
    return q


class Trainer:
    """Online and target networks, the optimizer and the update rule."""

    def __init__(self, network_config: NetworkConfig = NetworkConfig(),
                 config: TrainerConfig = TrainerConfig(), seed: int = 0, device: str = "cpu"):
        """device: where the networks train (network.resolve_device: cpu, cuda, cuda:N, auto); the
        weights are initialised on the CPU first, so a seed gives the same network on any device."""
        torch.manual_seed(seed)
        self.network_config, self.config = network_config, config
        self.device = resolve_device(device)
        self.online = QNetwork(network_config).to(self.device)
        self.target = copy.deepcopy(self.online).eval()
        for p in self.target.parameters():
            p.requires_grad_(False)
        self.optimizer = torch.optim.SGD(self.online.parameters(), lr=config.learning_rate,
                                         momentum=config.momentum, weight_decay=config.weight_decay)
        self.updates = 0

    # ---- inference ----------------------------------------------------------------------------
    def q_maps(self, state: State, use_target: bool = False) -> np.ndarray:
        """All 32 Q maps (R, 2, S, S) for one state."""
        return q_maps(self.target if use_target else self.online, state, self.device)

    def target_value(self, reward: float, next_state: State | None, next_allowed=(PUSH, GRASP)) -> float:
        if next_state is None:
            return float(reward)
        q = self.q_maps(next_state, use_target=True)
        masks = action_masks(next_state, allowed=next_allowed,
                             grasp_needs_object=self.config.grasp_needs_object)
        return float(reward) + self.config.gamma * best_action(q, masks, next_allowed).q_value

    # ---- learning -----------------------------------------------------------------------------
    def executed_q(self, transition: Transition) -> torch.Tensor:
        """Q(s, a; theta) at the executed pixel, for the executed rotation (and its opposite for a
        grasp): a (1,) or (2,) tensor with gradient."""
        rotations = [transition.rotation]
        num_rotations = self.network_config.num_rotations
        if transition.primitive == GRASP and self.config.grasp_trains_opposite:
            rotations.append((transition.rotation + num_rotations // 2) % num_rotations)
        inputs = network_inputs(transition.state.color, transition.state.height,
                                transition.state.mask).to(self.device)
        q = self.online.q_maps(inputs, rotations=rotations, chunk=None)
        row, col = transition.pixel
        return q[:, transition.primitive, row, col]

    def loss(self, transition: Transition, label: float) -> tuple:
        """(Huber loss summed over the trained pixels, predicted Q values) for one transition."""
        predicted = self.executed_q(transition)
        loss = F.huber_loss(predicted, torch.full_like(predicted, label), delta=self.config.huber_delta,
                            reduction="sum")
        return loss, predicted.detach()

    def update(self, transition: Transition, label: float | None = None) -> tuple:
        """One SGD step on one transition. Returns (loss, |Q - y| before the step, y); the middle
        one is the replay priority."""
        if label is None:
            label = self.target_value(transition.reward, transition.next_state, transition.next_allowed)
        self.online.train()
        loss, predicted = self.loss(transition, label)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        self.updates += 1
        if self.updates % self.config.target_sync_every == 0:
            self.sync_target()
        return float(loss.detach()), float((predicted - label).abs().max()), float(label)

    def sync_target(self) -> None:
        self.target.load_state_dict(self.online.state_dict())

    # ---- checkpoints --------------------------------------------------------------------------
    def state_dict(self, extra: dict | None = None) -> dict:
        return {"format_version": CHECKPOINT_FORMAT_VERSION,
                "network_config": self.network_config.to_dict(),
                "trainer_config": asdict(self.config),
                "online": self.online.state_dict(), "target": self.target.state_dict(),
                "optimizer": self.optimizer.state_dict(), "updates": self.updates,
                "extra": extra or {}}

    def save(self, path, extra: dict | None = None) -> None:
        """Atomic: written next to `path` and renamed, so a crash never leaves half a checkpoint."""
        path = pathlib.Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(path.suffix + ".tmp")
        torch.save(self.state_dict(extra), tmp)
        tmp.replace(path)

    def load(self, path, weights_only_network: bool = False) -> dict:
        """Restore from a checkpoint made with the same network config; returns its `extra`."""
        data = read_checkpoint(path, self.network_config)
        self.online.load_state_dict(data["online"])
        self.target.load_state_dict(data.get("target", data["online"]))
        if not weights_only_network and "optimizer" in data:
            self.optimizer.load_state_dict(data["optimizer"])
            self.updates = int(data.get("updates", 0))
        return data.get("extra", {})


