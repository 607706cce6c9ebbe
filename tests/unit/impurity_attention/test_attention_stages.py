"""attend's stages, each on its own: regions -> verifier -> looks (stall look, last look) -> product memory ->
heaps. Flat synthetic views of test_verifier (a grid of product blocks, one impurity block)."""

import dataclasses

import numpy as np
import pytest
from test_verifier import two_colour_view

from impurity_attention.core import attention as att
from impurity_attention.core import verifier as ver
from impurity_common.colour import ProductReference, lab

PARAMS = att.AttentionParams()


def coin(**thresholds):
    """A model that rates every region 0.5."""
    n = len(ver.FEATURES)
    return ver.RegionVerifier(mean=(0.0,) * n, scale=(1.0,) * n, coef=(0.0,) * n, intercept=0.0,
                              **{"threshold": 0.6, "last_look": 0.4, "stall_look": 0.3, **thresholds},
                              low=(-1e9,) * n, high=(1e9,) * n)


# ------------------------------------------------------------------------------------------ regions
def test_the_regions_stage_finds_the_impurity_block_as_a_region_of_object_cells():
    color, height, objects, impurity, _ = two_colour_view()
    scene = att.find_regions(color, height, PARAMS)
    assert np.array_equal(scene.objects, objects)
    assert scene.regions and all(not np.any(r.mask & ~objects) for r in scene.regions)
    assert any(np.count_nonzero(r.mask & impurity) > 0.5 * r.area for r in scene.regions)
    assert [r.score for r in scene.regions] == sorted((r.score for r in scene.regions), reverse=True)


def test_the_regions_stage_reads_nan_and_negative_heights_as_table():
    color, height, *_ = two_colour_view()
    height[0, 0], height[0, 1] = np.nan, -0.5
    scene = att.find_regions(color, height, PARAMS)
    assert scene.height[0, 0] == 0.0 and scene.height[0, 1] == 0.0


def test_an_empty_table_has_no_region():
    scene = att.find_regions(np.zeros((60, 60, 3), np.uint8), np.zeros((60, 60), np.float32), PARAMS)
    assert scene.regions == [] and not scene.objects.any()


# ------------------------------------------------------------------------------------------ verifier
def test_the_verifier_stage_rates_at_most_the_top_regions_and_orders_them_likeliest_first():
    color, height, _, impurity, _ = two_colour_view()
    scene = att.find_regions(color, height, PARAMS)
    verdict = att.verify(scene, PARAMS, ver.default_verifier())
    assert len(verdict.candidates) == min(ver.TOP_REGIONS, len(scene.regions))
    assert list(verdict.probability[verdict.order]) == sorted(verdict.probability, reverse=True)
    likeliest = verdict.candidates[verdict.order[0]]
    assert np.count_nonzero(likeliest.mask & impurity) > 0.5 * likeliest.area


@pytest.mark.parametrize("contrast, probability", [(0.0, 1.0), (1e9, 0.0)])
def test_a_lone_region_with_every_object_in_it_is_judged_by_its_saliency_alone(contrast, probability):
    color, height = np.zeros((60, 60, 3), np.uint8), np.zeros((60, 60), np.float32)
    color[20:40, 20:40], height[20:40, 20:40] = (200, 60, 40), 0.03
    scene = att.find_regions(color, height, PARAMS)
    assert len(scene.regions) == 1 and np.array_equal(scene.regions[0].mask, scene.objects)
    params = dataclasses.replace(PARAMS, min_relative_contrast=contrast)
    assert list(att.verify(scene, params, ver.default_verifier()).probability) == [probability]


# ------------------------------------------------------------------------------------------ looks
def test_a_target_needs_the_models_threshold_and_on_a_stall_look_its_stall_look():
    model = coin()
    assert att.decision_threshold(model, closer=False) == (0.6, "")
    assert att.decision_threshold(model, closer=True) == (0.3, " (stall look)")


def test_the_last_look_takes_a_region_from_the_models_last_look_on():
    model = coin(last_look=0.4)
    assert att.last_look(0.4, model) and att.last_look(0.5, model)
    assert not att.last_look(0.39, model)


# ------------------------------------------------------------------------------------------ product memory
def verdict_of(probabilities):
    regions = [att.SalientRegion(np.zeros((4, 4), bool), 1, 1.0, 1.0, (0.0, 0.0)) for _ in probabilities]
    probability = np.array(probabilities)
    return att.Verdict(tuple(regions), probability, [int(i) for i in np.argsort(-probability, kind="stable")])


RED, BLUE = lab(np.array([200, 60, 40], np.uint8))[0], lab(np.array([40, 120, 200], np.uint8))[0]
BLUE_PRODUCT = ProductReference.from_colors(np.tile([40, 120, 200], (100, 1)), 4.0)


def test_a_region_coloured_like_the_known_product_is_passed_over_and_the_next_one_judged():
    verdict = verdict_of([0.9, 0.5])
    colours = {0: BLUE, 1: RED}
    order, probability, note = att.pass_over_known_product(verdict, BLUE_PRODUCT, colours.get, PARAMS)
    assert order == [1] and probability is verdict.probability
    assert note.startswith("; region 1 (0.90) coloured like 100.0 % of the known product > 1.0 %")


def test_the_pass_stops_at_the_first_region_not_coloured_like_the_product():
    read = []

    def colour_of(i):
        read.append(i)
        return RED

    order, _, note = att.pass_over_known_product(verdict_of([0.9, 0.5, 0.2]), BLUE_PRODUCT, colour_of, PARAMS)
    assert order == [0, 1, 2] and note == "" and read == [0]


def test_with_every_region_coloured_like_the_product_the_first_is_kept_at_probability_0():
    order, probability, _ = att.pass_over_known_product(verdict_of([0.9, 0.5]), BLUE_PRODUCT,
                                                        lambda i: BLUE, PARAMS)
    assert order == [0] and list(probability) == [0.0, 0.0]


# ------------------------------------------------------------------------------------------ heaps
def test_a_tall_heap_is_the_occluded_region_and_a_flat_layer_is_none():
    height = np.zeros((100, 100), np.float32)
    height[20:60, 20:60] = 0.06
    assert att.Heaps(height, 0.002, PARAMS.density).occluded_region is not None
    height[20:60, 20:60] = 0.02
    heaps = att.Heaps(height, 0.002, PARAMS.density)
    assert heaps.clusters and heaps.occluded_region is None


def test_heaps_are_clustered_once():
    heaps = att.Heaps(np.zeros((50, 50), np.float32), 0.002, PARAMS.density)
    assert heaps.clusters is heaps.clusters
