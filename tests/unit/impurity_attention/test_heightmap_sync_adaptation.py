"""Colour/depth pairing by stamp and the optional Reinhard colour adaptation."""

import numpy as np
import pytest

from impurity_attention.core.colour_adaptation import LabStatistics, lab_statistics, reinhard_transfer
from impurity_attention.core.sync import StampPairer


def test_exact_stamps_pair_in_either_order():
    pairer = StampPairer()
    assert pairer.add_color(100, "c100") is None
    assert pairer.add_depth(100, "d100") == ("c100", "d100")
    assert pairer.add_depth(200, "d200") is None
    assert pairer.add_color(200, "c200") == ("c200", "d200")


def test_tolerance_picks_the_closest_partner():
    pairer = StampPairer(tolerance_ns=10)
    pairer.add_depth(100, "d100")
    pairer.add_depth(108, "d108")
    assert pairer.add_color(105, "c105") == ("c105", "d108")  # 3 ns away beats 5 ns
    assert StampPairer(tolerance_ns=2).add_color(1, "c") is None


def test_lost_frames_do_not_block_later_pairs():
    pairer = StampPairer(capacity=3)
    for stamp in range(10):
        pairer.add_color(stamp, f"c{stamp}")  # depth for these never comes
    assert pairer.add_depth(9, "d9") == ("c9", "d9")
    assert pairer.dropped >= 7
    assert pairer.add_depth(10, "d10") is None and pairer.add_color(10, "c10") == ("c10", "d10")


def test_pairer_arguments_are_checked():
    with pytest.raises(ValueError):
        StampPairer(tolerance_ns=-1)


def test_reinhard_transfer_matches_reference_statistics():
    rng = np.random.default_rng(0)
    sim = rng.normal((120, 130, 140), 20, (64, 64, 3)).clip(0, 255).astype(np.uint8)
    real = rng.normal((90, 100, 70), 35, (64, 64, 3)).clip(0, 255).astype(np.uint8)
    reference = lab_statistics([sim])
    adapted = reinhard_transfer(real, reference)
    got = lab_statistics([adapted])
    assert got.mean == pytest.approx(reference.mean, abs=1.5)
    assert got.std == pytest.approx(reference.std, rel=0.1, abs=0.5)


def test_reinhard_keeps_invalid_pixels_and_survives_flat_images():
    image = np.zeros((8, 8, 3), np.uint8)
    image[2:6, 2:6] = (200, 30, 30)
    valid = image.any(axis=2)
    out = reinhard_transfer(image, LabStatistics((50.0, 0.0, 0.0), (10.0, 5.0, 5.0)), valid)
    assert not out[~valid].any()
    assert out.dtype == np.uint8 and out.shape == image.shape
    nothing_valid = np.zeros((8, 8), bool)
    flat = LabStatistics((50, 0, 0), (1, 1, 1))
    assert np.array_equal(reinhard_transfer(image, flat, nothing_valid), image)
