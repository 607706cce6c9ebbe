"""The impurity network's input, output and weights file (impurity_attention.core.impurity_net) and the two
verifier features it gives (verifier.NETWORK_FEATURES)."""

import numpy as np
import pytest
import torch

from impurity_attention.core import attention as att
from impurity_attention.core import impurity_net as net_module
from impurity_attention.core import verifier as ver
from impurity_attention.core.impurity_net import (
    HEIGHT_SCALE,
    ImpurityNet,
    NetworkFileError,
    pooled,
    read_network,
    scene_planes,
    write_network,
)

THRESHOLDS = {"threshold": 0.5, "last_look": 0.3, "stall_look": 0.2}  # a model's, where they do not matter


def view(size=(48, 40), product=(40, 120, 200), impurity=(200, 60, 40)):
    """A flat product of one colour with an 8 x 8 impurity block; the border row and column are table."""
    color = np.zeros((*size, 3), np.uint8)
    height = np.zeros(size, np.float32)
    color[1:-1, 1:-1], height[1:-1, 1:-1] = product, 0.03
    target = np.zeros(size, bool)
    target[10:18, 10:18] = True
    color[target] = impurity
    return color, height, height > 0.008, target


def seeded_net(seed=0):
    torch.manual_seed(seed)
    return ImpurityNet(width=8).eval()


def test_the_planes_read_each_cell_against_the_scenes_median_and_leave_the_table_at_zero():
    color, height, objects, target = view()
    planes = scene_planes(color, height, objects)
    assert planes.shape == (4, *objects.shape) and planes.dtype == np.float32
    product = objects & ~target
    assert np.allclose(planes[:3][:, product], 0.0, atol=1e-4)  # the product is the median
    assert np.abs(planes[:3][:, target]).max() > 5.0  # the impurity lies many spreads away
    assert np.all(planes[:, ~objects] == 0.0)
    assert np.allclose(planes[3][objects], 0.03 * HEIGHT_SCALE)


def test_the_planes_of_a_view_without_objects_are_zero():
    color, height, _, _ = view()
    assert not scene_planes(color, height, np.zeros(height.shape, bool)).any()


def test_pooling_pads_with_empty_cells_to_the_networks_multiple_and_averages_blocks():
    planes = np.ones((4, 13, 17), np.float32)
    small = pooled(planes)
    assert small.shape == (4, 16 // net_module.POOL, 24 // net_module.POOL)
    assert small[0, 0, 0] == 1.0 and small[0, -1, -1] == 0.0  # padding is empty


@pytest.mark.parametrize("size", [(48, 40), (45, 37), (224, 224)])
def test_the_probability_map_has_the_views_size_and_is_a_probability(size):
    color, height, objects, _ = view(size)
    probability = seeded_net().probability(color, height, objects)
    assert probability.shape == size and probability.dtype == np.float32
    assert np.all((probability >= 0.0) & (probability <= 1.0))


def test_the_weights_file_round_trips_in_half_precision(tmp_path):
    net = seeded_net()
    path = tmp_path / "net.pt"
    write_network(net, path, "a test")
    back = read_network(path)
    assert back.provenance == "a test" and back.width == net.width and not back.training
    color, height, objects, _ = view()
    moved = back.probability(color, height, objects) - net.probability(color, height, objects)
    assert np.abs(moved).max() < 5e-3


def test_a_bad_weights_file_is_refused_with_its_reason(tmp_path):
    with pytest.raises(NetworkFileError, match="does not exist"):
        read_network(tmp_path / "missing.pt")
    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(b"not a torch file")
    with pytest.raises(NetworkFileError, match="cannot be read"):
        read_network(garbage)
    data = net_module.network_dict(seeded_net(), "")
    torch.save({**data, "format_version": 99}, tmp_path / "v99.pt")
    with pytest.raises(NetworkFileError, match="format version 99"):
        read_network(tmp_path / "v99.pt")
    torch.save({**data, "width": 16}, tmp_path / "width.pt")
    with pytest.raises(NetworkFileError, match="has shape"):
        read_network(tmp_path / "width.pt")
    weights = dict(data["state_dict"])
    weights.pop("out.bias")
    torch.save({**data, "state_dict": weights}, tmp_path / "short.pt")
    with pytest.raises(NetworkFileError, match="missing \\['out.bias'\\]"):
        read_network(tmp_path / "short.pt")


def test_the_network_features_read_the_map_over_the_region_and_only_a_network_adds_them():
    color, height, objects, target = view()
    regions = [att.SalientRegion(mask=target, area=int(target.sum()), score=2.0, peak=2.0,
                                 centroid=(13.5, 13.5))]
    maps = att.scene_maps(color, objects, att.AttentionParams())[1]
    net = seeded_net()
    (_, with_net), = ver.candidate_features(color, height, objects, maps, regions, network=net)
    (_, without), = ver.candidate_features(color, height, objects, maps, regions)
    assert len(with_net) == len(ver.ALL_FEATURES) and len(without) == len(ver.FEATURES)
    values = net.probability(color, height, objects)[target]
    columns = [ver.ALL_FEATURES.index(name) for name in ver.NETWORK_FEATURES]
    assert with_net[columns] == pytest.approx([values.mean(), np.quantile(values, ver.NETWORK_QUANTILE)])
    assert np.array_equal(with_net[:len(ver.FEATURES)], without, equal_nan=True)


class CountingNet(ImpurityNet):
    def __init__(self):
        torch.manual_seed(0)
        super().__init__(width=8)
        self.calls = 0

    def probability(self, color, height, objects):
        self.calls += 1
        return super().probability(color, height, objects)


def test_attention_runs_the_network_for_a_model_that_reads_its_features_and_only_then():
    color, height, _, _ = view(size=(96, 96))
    n = len(ver.ALL_FEATURES)
    model = ver.RegionVerifier(mean=(0.0,) * n, scale=(1.0,) * n, coef=(0.0,) * n, intercept=0.0,
                               **THRESHOLDS, low=(-1e9,) * n, high=(1e9,) * n, features=ver.ALL_FEATURES)
    lean = ver.RegionVerifier(mean=(0.0,), scale=(1.0,), coef=(0.0,), intercept=0.0, **THRESHOLDS,
                              low=(-1e9,), high=(1e9,), features=("colour_contrast",))
    assert model.reads_network and not lean.reads_network
    for verifier, calls in ((model, 1), (lean, 0)):
        net = CountingNet()
        att.attend(color, height, att.AttentionParams(verifier=verifier, impurity_net=net))
        assert net.calls == calls
