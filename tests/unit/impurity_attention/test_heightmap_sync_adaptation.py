"""Colour/depth pairing by stamp and the optional Reinhard colour adaptation."""

import numpy as np
import pytest

from impurity_attention.core.colour_adaptation import LabStatistics, lab_statistics, reinhard_transfer
from impurity_attention.core.sync import StampPairer, StreamWatch


def test_exact_stamps_pair_in_either_order():
    pairer = StampPairer()
    assert pairer.add_color(100, "c100") == []
    assert pairer.add_depth(100, "d100") == [("c100", "d100")]
    assert pairer.add_depth(200, "d200") == []
    assert pairer.add_color(200, "c200") == [("c200", "d200")]


def test_tolerance_picks_the_closest_partner():
    pairer = StampPairer(tolerance_ns=10)
    pairer.add_depth(100, "d100")
    pairer.add_depth(108, "d108")
    assert pairer.add_color(105, "c105") == [("c105", "d108")]  # 3 ns away beats 5 ns
    assert StampPairer(tolerance_ns=2).add_color(1, "c") == []


def test_lost_frames_do_not_block_later_pairs():
    pairer = StampPairer(capacity=3)
    for stamp in range(10):
        pairer.add_color(stamp, f"c{stamp}")  # depth for these never comes
    assert pairer.add_depth(9, "d9") == [("c9", "d9")]
    assert pairer.dropped >= 7
    assert pairer.add_depth(10, "d10") == [] and pairer.add_color(10, "c10") == [("c10", "d10")]


def test_pairer_arguments_are_checked():
    with pytest.raises(ValueError):
        StampPairer(tolerance_ns=-1)
    with pytest.raises(ValueError):
        StampPairer(period_fraction=0.8)


PERIOD_15HZ = 1_000_000_000 // 15


def offset_stream(frames: int, offset_ns: int, depth_first: bool = False):
    """(side, stamp) arrivals of a 15 Hz camera whose depth is stamped `offset_ns` after its colour."""
    for index in range(frames):
        color = ("color", 5_000_000_000 + index * PERIOD_15HZ)
        depth = ("depth", color[1] + offset_ns)
        yield from ((depth, color) if depth_first else (color, depth))


def feed(pairer: StampPairer, arrivals) -> list:
    pairs = []
    for side, stamp in arrivals:
        add = pairer.add_color if side == "color" else pairer.add_depth
        pairs += add(stamp, stamp)
    return pairs


@pytest.mark.parametrize("depth_first", [False, True])
def test_depth_20ms_after_colour_at_15hz_pairs_every_frame_by_default(depth_first):
    """A driver stamps depth 20 ms after its colour frame; a fixed 10 ms tolerance paired
    none of 30. The default pairs within half the measured period (33 ms), each with its own partner."""
    pairer = StampPairer()
    pairs = feed(pairer, offset_stream(30, 20_000_000, depth_first))
    assert len(pairs) == 30
    assert all(depth - color == 20_000_000 for color, depth in pairs)
    assert pairer.period_ns == PERIOD_15HZ and pairer.tolerance_ns == PERIOD_15HZ // 2
    assert pairer.dropped == 0 and pairer.take_unpaired() == []


def test_a_fixed_tolerance_below_the_offset_pairs_nothing_and_says_by_how_much():
    pairer = StampPairer(tolerance_ns=10_000_000)
    assert feed(pairer, offset_stream(30, 20_000_000)) == []
    unpaired = pairer.take_unpaired()
    assert len(unpaired) >= 50 and pairer.dropped == len(unpaired)
    assert {frame.offset_ns for frame in unpaired} == {20_000_000}  # depth - colour, either side's frames
    assert {frame.tolerance_ns for frame in unpaired} == {10_000_000}
    assert not any(frame.partner_lost for frame in unpaired)  # the tolerance is the cause, not a loss
    assert pairer.take_unpaired() == []


@pytest.mark.parametrize("seed", range(10))
def test_frames_lost_in_transport_never_mispair_and_are_told_apart_from_a_tight_tolerance(seed):
    """A lossy transport (a third of each stream lost at random): once the period is measured every pair
    is a frame and its own partner, and each frame left alone is reported as lost, not as too far."""
    rng = np.random.default_rng(seed)
    pairer, pairs = StampPairer(), []
    for side, stamp in offset_stream(100, 20_000_000):
        if rng.random() < 1 / 3:
            continue
        made = (pairer.add_color if side == "color" else pairer.add_depth)(stamp, stamp)
        if pairer.period_ns == PERIOD_15HZ:
            pairs += made
            assert all(frame.partner_lost for frame in pairer.take_unpaired())
    assert pairer.period_ns == PERIOD_15HZ
    assert len(pairs) > 30 and all(depth - color == 20_000_000 for color, depth in pairs)


def test_a_missing_stream_is_reported_without_an_offset():
    pairer = StampPairer(capacity=2)
    for index in range(4):
        pairer.add_color(index * PERIOD_15HZ, index)
    unpaired = pairer.take_unpaired()
    assert [frame.side for frame in unpaired] == ["color", "color"]
    assert all(frame.offset_ns is None for frame in unpaired)


def test_the_automatic_tolerance_never_pairs_a_frame_with_its_neighbours_partner():
    """Depth frames every other period lost: the colour frames without one stay unpaired instead of
    taking a neighbour's depth (a period away, beyond half a period)."""
    pairer = StampPairer()
    arrivals = [arrival for arrival in offset_stream(20, 5_000_000)
                if arrival[0] == "color" or (arrival[1] // PERIOD_15HZ) % 2 == 0]
    pairs = feed(pairer, arrivals)
    assert pairs and all(depth - color == 5_000_000 for color, depth in pairs)
    assert all(frame.side == "color" for frame in pairer.take_unpaired())



def test_a_stream_that_never_delivered_is_silent_once_the_timeout_has_passed_since_the_start():
    watch = StreamWatch(("color", "depth", "info"), now=100.0)
    assert watch.silent(104.0, timeout=5.0) == {}
    assert watch.silent(106.0, timeout=5.0) == {"color": 6.0, "depth": 6.0, "info": 6.0}


def test_a_message_makes_its_stream_heard_and_leaves_the_others_silent():
    watch = StreamWatch(("color", "depth", "info"), now=0.0)
    watch.seen("color", 8.0)
    watch.seen("info", 9.0)
    assert watch.silent(10.0, timeout=5.0) == {"depth": 10.0}
    assert watch.silent(20.0, timeout=5.0) == {"color": 12.0, "depth": 20.0, "info": 11.0}


def test_the_watch_is_off_at_timeout_zero_and_refuses_an_unknown_stream():
    watch = StreamWatch(("color",), now=0.0)
    assert watch.silent(1000.0, timeout=0.0) == {}
    with pytest.raises(KeyError, match="unknown stream 'depth'; watched: color"):
        watch.seen("depth", 1.0)

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
