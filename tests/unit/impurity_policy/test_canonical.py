"""canonical.canonical_colours: the network's colour crop repainted in the default palette, by class (target,
product, table), with each cell's lightness against its class kept."""

import numpy as np

from impurity_policy.core.canonical import REFERENCE_RGB, canonical_colours


def crop(product=(120, 100, 60), impurity=(90, 90, 90), table=(200, 200, 190), size=32):
    """A table with a product block (left half lit, right half at 60 % light) and an impurity block."""
    color = np.zeros((size, size, 3), np.uint8)
    height = np.zeros((size, size), np.float32)
    color[:] = table
    color[4:14, 4:9], color[4:14, 9:14] = product, (np.array(product) * 0.6).astype(np.uint8)
    height[4:14, 4:14] = 0.04
    color[18:26, 18:26] = impurity
    height[18:26, 18:26] = 0.03
    mask = np.zeros((size, size), np.uint8)
    mask[18:26, 18:26] = 1
    return color, height, mask


def test_each_class_takes_the_default_palettes_colour_and_keeps_its_shading():
    color, height, mask = crop()
    out = canonical_colours(color, height, mask, target_mode=True)
    assert np.allclose(out[20, 20], REFERENCE_RGB["target"], atol=1)
    assert np.allclose(out[0, 0], REFERENCE_RGB["table"], atol=1)
    lit, shaded = out[8, 5].astype(float), out[8, 12].astype(float)
    assert np.allclose(shaded / lit, 0.6, atol=0.02)  # the product's shaded face stays as much darker
    assert np.argmax(lit) == 2  # blue, as the default palette's product


def test_the_same_scene_in_two_palettes_looks_alike_to_the_network():
    one = canonical_colours(*crop(product=(120, 100, 60), impurity=(90, 90, 90)), target_mode=True)
    two = canonical_colours(*crop(product=(30, 160, 40), impurity=(200, 40, 200)), target_mode=True)
    assert np.abs(one.astype(int) - two.astype(int)).max() <= 3  # rounding of the shaded face only


def test_without_a_target_every_object_is_product_and_the_input_is_left_alone():
    color, height, mask = crop()
    before = color.copy()
    out = canonical_colours(color, height, np.ones_like(mask), target_mode=False)  # an occluded region
    assert np.allclose(out[20, 20], REFERENCE_RGB["product"], atol=1)
    assert np.array_equal(color, before)


def test_a_policy_with_canonical_colours_gives_the_same_q_maps_under_either_palette():
    import torch

    from impurity_policy.core.network import NetworkConfig, QNetwork
    from impurity_policy.core.policy import MODE_TARGET, Observation, Policy
    from impurity_policy.core.rules import RulePipeline

    torch.manual_seed(0)
    network = QNetwork(NetworkConfig(stem_channels=8, growth=8, block_layers=(2, 2), head_channels=16))

    def q(policy, product, impurity):
        color, height, mask = crop(product=product, impurity=impurity, size=112)
        return policy.q_maps(Observation(MODE_TARGET, color, height, mask, (0, 0), height))

    canonical, plain = Policy(network, rules=RulePipeline(("canonical_colours",))), Policy(network)
    one, two = ((100, 100, 60), (90, 90, 90)), ((50, 150, 40), (200, 40, 200))  # shaded faces exactly 0.6
    assert np.allclose(q(canonical, *one), q(canonical, *two), atol=1e-5)
    assert not np.allclose(q(plain, *one), q(plain, *two), atol=1e-3)
