"""Training of the impurity network (impurity_attention.core.impurity_net), self-supervised from rendered
views: the simulator knows which cells show an impurity (a record's visible_target_cells), so no view is
labelled by hand. `python -m impurity_learning.calibrate network` trains it on tuning palettes and tuning
seeds only.

Recipe (train_impurity_net): per view, the pooled scene planes (impurity_net.scene_planes, pooled) of the view
with its RGB scaled by an exposure drawn log-uniformly in `exposure` (clipped at 255, a saturating camera;
one draw per view and epoch), the label the pooled impurity cells, the weight the pooled object cells (an
impurity cell counts positive_weight times). Loss: binary cross-entropy over the weighted cells, summed and
divided by the weights' sum. Each batch is turned by a random quarter turn and mirrored with probability 1/2
(a heightmap has no preferred direction), Adam, seeded: the same views give the same network up to
floating-point order.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

from impurity_attention.core.evaluation import exposed_color
from impurity_attention.core.impurity_net import ImpurityNet, pooled, scene_planes

POSITIVE_WEIGHT = 5.0  # an impurity cell's weight in the loss (they are a few % of the object cells)
BATCH = 16
LEARNING_RATE = 2e-3


def train_impurity_net(views: Sequence, epochs: int, exposure: tuple = (0.5, 2.0), seed: int = 0,
                       width: int = 24, positive_weight: float = POSITIVE_WEIGHT, batch: int = BATCH,
                       learning_rate: float = LEARNING_RATE, progress: bool = True) -> tuple:
    """Train an ImpurityNet (module docstring). views: (color (H, W, 3) uint8, height (H, W) m, objects (H, W)
    bool, impurity cells (H, W) bool) of one size; exposure: (low, high) factors (low = high = 1: none).
    Returns (the network in eval mode, the mean loss of each epoch). ValueError on no views, views of
    different sizes, epochs < 1 or positive_weight <= 0."""
    if not views:
        raise ValueError("train_impurity_net needs at least one view")
    if epochs < 1:
        raise ValueError(f"epochs must be >= 1, got {epochs}")
    if not positive_weight > 0:
        raise ValueError(f"positive_weight must be > 0 (an impurity cell's weight in the loss), got "
                         f"{positive_weight}")
    shape = np.asarray(views[0][2]).shape
    if any(np.asarray(v[2]).shape != shape for v in views):
        raise ValueError(f"train_impurity_net needs views of one size; the first is {shape}")
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    labels = torch.from_numpy(np.stack([pooled((np.asarray(t) & np.asarray(o)).astype(np.float32)[None])[0]
                                        for _, _, o, t in views]))
    masks = torch.from_numpy(np.stack([pooled(np.asarray(o, np.float32)[None])[0] for _, _, o, _ in views]))
    low, high = np.log(exposure)
    net = ImpurityNet(width)
    net.train()
    optimiser = torch.optim.Adam(net.parameters(), lr=learning_rate)
    losses = []
    steps = range(0, len(views), batch)
    for epoch in range(epochs):
        order = rng.permutation(len(views))
        total = 0.0
        bar = _progress(steps, f"impurity net epoch {epoch + 1}/{epochs}", progress)
        for number, start in enumerate(bar):
            chosen = order[start:start + batch]
            factors = [float(np.exp(rng.uniform(low, high))) for _ in chosen]
            x = torch.from_numpy(np.stack([
                pooled(scene_planes(exposed_color(views[i][0], factor), views[i][1], views[i][2]))
                for i, factor in zip(chosen, factors, strict=True)]))
            index = torch.from_numpy(chosen)
            y, m = labels[index][:, None], masks[index][:, None]
            turns = int(rng.integers(4))
            x, y, m = (torch.rot90(t, turns, (2, 3)) for t in (x, y, m))
            if rng.random() < 0.5:
                x, y, m = (torch.flip(t, (3,)) for t in (x, y, m))
            weight = m * (1.0 + (positive_weight - 1.0) * y)
            loss = nn.functional.binary_cross_entropy_with_logits(net(x), y, weight=weight, reduction="sum")
            loss = loss / weight.sum().clamp(min=1.0)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total += loss.item()
            if progress:
                bar.set_postfix(loss=f"{total / (number + 1):.4f}")
        losses.append(total / len(steps))
        print(f"impurity net epoch {epoch + 1}: mean loss {losses[-1]:.4f}", flush=True)
    return net.eval(), losses


def _progress(steps, description: str, shown: bool):
    if not shown:
        return steps
    from tqdm import tqdm
    return tqdm(steps, desc=description)
