"""The impurity network's trainer (impurity_learning.impurity_net_training): what it refuses, that it is
seeded, and that it learns to mark the cells that look unlike the product around them whatever the colours."""

import numpy as np
import pytest

from impurity_attention.core.evaluation import exposed_color
from impurity_learning.impurity_net_training import train_impurity_net


def palette_view(seed: int, size: int = 40):
    """A flat product of one random colour (blocks of 8 cells, each shade jittered) with one 8 x 8 impurity
    block of another random colour at a random place. Returns (color, height, objects, impurity cells)."""
    rng = np.random.default_rng(seed)
    product, impurity = rng.integers(30, 226, size=3), rng.integers(30, 226, size=3)
    while np.abs(product - impurity).sum() < 120:
        impurity = rng.integers(30, 226, size=3)
    color = np.zeros((size, size, 3), np.uint8)
    for row in range(0, size, 8):
        for col in range(0, size, 8):
            color[row:row + 8, col:col + 8] = np.clip(product * rng.uniform(0.92, 1.08), 0, 255)
    target = np.zeros((size, size), bool)
    row, col = 8 * rng.integers(0, size // 8, size=2)
    target[row:row + 8, col:col + 8] = True
    color[target] = impurity
    height = np.full((size, size), 0.03, np.float32)
    return color, height, np.ones((size, size), bool), target


def test_it_refuses_no_views_no_epochs_views_of_different_sizes_and_a_weight_not_above_zero():
    with pytest.raises(ValueError, match="at least one view"):
        train_impurity_net([], 1)
    with pytest.raises(ValueError, match="epochs"):
        train_impurity_net([palette_view(0)], 0)
    with pytest.raises(ValueError, match="one size"):
        train_impurity_net([palette_view(0), palette_view(1, size=48)], 1)
    for weight in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="positive_weight"):
            train_impurity_net([palette_view(0)], 1, positive_weight=weight)


def test_exposure_scales_and_clips_like_a_saturating_camera():
    color = np.array([[[100, 200, 10]]], np.uint8)
    assert exposed_color(color, 2.0).tolist() == [[[200, 255, 20]]]
    assert exposed_color(color, 0.5).tolist() == [[[50, 100, 5]]]


def test_the_same_views_and_seed_give_the_same_network():
    views = [palette_view(seed) for seed in range(4)]
    _, first = train_impurity_net(views, 2, width=8, batch=2, progress=False)
    _, second = train_impurity_net(views, 2, width=8, batch=2, progress=False)
    assert first == pytest.approx(second, rel=1e-5)


def test_it_learns_to_mark_the_odd_block_on_palettes_it_never_saw():
    net, losses = train_impurity_net([palette_view(seed) for seed in range(24)], 25, width=8, batch=8,
                                     progress=False)
    assert losses[-1] < 0.6 * losses[0]
    hits = 0
    for seed in range(100, 110):  # products and impurities of colours it was not trained on
        color, height, objects, target = palette_view(seed)
        probability = net.probability(color, height, objects)
        hits += probability[target].mean() > 2.0 * probability[~target].mean()
    assert hits >= 8
