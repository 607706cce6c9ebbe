"""The learned region verifier (impurity_attention.core.verifier): what its features measure, how the model
is checked, and how attention decides with it."""

import dataclasses
import json

import numpy as np
import pytest

from impurity_attention.core import attention as att
from impurity_attention.core import verifier as ver
from impurity_attention.core.attention import shipped_network

THRESHOLDS = {"threshold": 0.5, "last_look": 0.3, "stall_look": 0.2}  # a model's, where they do not matter


def two_colour_view(impurity=(200, 60, 40), product=(40, 120, 200), size=60, block=12):
    """A flat view: a grid of product blocks of slightly varied shade, one block (the first of the third
    row) in `impurity`'s colour. Returns (color, height, objects, impurity cells, a product block)."""
    rng = np.random.default_rng(0)
    color = np.zeros((size, size, 3), np.uint8)
    height = np.zeros((size, size), np.float32)
    impurity_cells = np.zeros((size, size), bool)
    product_block = np.zeros((size, size), bool)
    for row in range(0, size, block):
        for col in range(0, size, block):
            cells = (slice(row + 1, row + block - 1), slice(col + 1, col + block - 1))
            shade = np.clip(np.array(product) * rng.uniform(0.9, 1.1), 0, 255)
            if (row, col) == (2 * block, 0):
                shade = impurity
                impurity_cells[cells] = True
            elif (row, col) == (0, 0):
                product_block[cells] = True
            color[cells] = shade
            height[cells] = 0.03
    objects = height > 0.008
    return color, height, objects, impurity_cells, product_block


def conspicuity_of(color, objects):
    return att.scene_maps(color, objects, att.AttentionParams())[1]


def test_an_impurity_of_another_hue_stands_apart_in_colour_and_a_product_block_does_not():
    color, height, objects, impurity, product = two_colour_view()
    maps = conspicuity_of(color, objects)
    odd = dict(zip(ver.REGION_FEATURES, ver.region_features(color, height, objects, maps, impurity),
                   strict=True))
    same = dict(zip(ver.REGION_FEATURES, ver.region_features(color, height, objects, maps, product),
                    strict=True))
    assert odd["colour_contrast"] > same["colour_contrast"] + 1.0
    assert odd["off_colour_share"] > 0.9 > 0.1 > same["off_colour_share"]
    assert odd["relative_rg"] > same["relative_rg"]


def test_a_darker_impurity_is_darker_than_the_products_own_spread():
    color, height, objects, impurity, product = two_colour_view(impurity=(16, 48, 80))
    maps = conspicuity_of(color, objects)
    odd = dict(zip(ver.REGION_FEATURES, ver.region_features(color, height, objects, maps, impurity),
                   strict=True))
    same = dict(zip(ver.REGION_FEATURES, ver.region_features(color, height, objects, maps, product),
                    strict=True))
    assert odd["lightness_offset"] < -3.0 < same["lightness_offset"]
    assert odd["dark_share"] == pytest.approx(1.0) and same["dark_share"] < 0.5


def region(cells, score):
    rows, cols = np.nonzero(cells)
    return att.SalientRegion(mask=cells, area=int(cells.sum()), score=score, peak=score,
                             centroid=(float(rows.mean()), float(cols.mean())))


def test_context_features_place_a_region_among_the_others():
    _, _, objects, impurity, product = two_colour_view()
    regions = [region(impurity, 4.0), region(product, 1.0)]
    first = dict(zip(ver.CONTEXT_FEATURES, ver.context_features(objects, regions, 0), strict=True))
    second = dict(zip(ver.CONTEXT_FEATURES, ver.context_features(objects, regions, 1), strict=True))
    assert (first["rank"], second["rank"]) == (0.0, 1.0)
    assert first["log_regions"] == pytest.approx(np.log(2))
    assert first["best_over_next"] == second["best_over_next"] == pytest.approx(np.log(4))
    assert first["log_object_share"] == pytest.approx(np.log(objects.mean()))
    alone = dict(zip(ver.CONTEXT_FEATURES, ver.context_features(objects, regions[:1], 0), strict=True))
    assert alone["best_over_next"] == pytest.approx(np.log(2))  # one region: as if the next were half


def test_a_feature_beyond_the_fitted_range_counts_as_its_end():
    model = ver.default_verifier()
    inside = np.zeros(len(ver.ALL_FEATURES))
    inside[[ver.ALL_FEATURES.index(name) for name in model.features]] = model.high
    beyond = inside.copy()
    beyond[ver.ALL_FEATURES.index("log_object_share")] = 0.0  # a view full of objects
    assert model.probability(beyond) == pytest.approx(model.probability(inside))


def test_a_model_reads_the_features_it_names_and_no_others():
    names = ("colour_contrast", "rank")
    model = ver.RegionVerifier(mean=(0.0, 0.0), scale=(1.0, 1.0), coef=(1.0, -1.0), intercept=0.0,
                               **THRESHOLDS, low=(-9.0, -9.0), high=(9.0, 9.0), features=names)
    row = np.full(len(ver.FEATURES), 5.0)  # every other feature: anything
    row[ver.FEATURES.index("colour_contrast")], row[ver.FEATURES.index("rank")] = 2.0, 1.0
    assert model.probability(row)[0] == pytest.approx(1.0 / (1.0 + np.exp(-1.0)))
    # the shipped model: all fifteen and the network's two
    assert ver.default_verifier().features == ver.ALL_FEATURES
    assert ver.default_verifier().reads_oriented and not model.reads_oriented
    assert ver.default_verifier().reads_network and not model.reads_network


def test_the_oriented_features_are_computed_only_for_a_model_that_reads_them():
    color, height, objects, impurity, _ = two_colour_view()
    maps = conspicuity_of(color, objects)
    full = ver.region_features(color, height, objects, maps, impurity)
    lean = ver.region_features(color, height, objects, maps, impurity, oriented=False)
    oriented = [ver.REGION_FEATURES.index(name) for name in ver.ORIENTED_FEATURES]
    assert np.all(lean[oriented] == 0.0) and np.any(full[oriented] != 0.0)
    assert np.array_equal(np.delete(full, oriented), np.delete(lean, oriented))  # the others alike


def test_a_view_read_once_gives_every_region_the_features_it_gets_alone():
    """candidate_features reads the view's planes once (ViewPlanes) for all its regions: the features are
    the ones each region gets when read on its own, bit for bit."""
    color, height, objects, impurity, product = two_colour_view()
    height = height + np.linspace(0.0, 0.01, height.shape[1], dtype=np.float32) * objects  # some slope
    maps = conspicuity_of(color, objects)
    planes = ver.ViewPlanes.of(color, height)
    for region in (impurity, product):
        alone = ver.region_features(color, height, objects, maps, region)
        shared = ver.region_features(color, height, objects, maps, region, planes=planes)
        assert np.array_equal(alone, shared, equal_nan=True)
    lean = ver.ViewPlanes.of(color)  # no height: what the lightness features read, not the oriented
    assert lean.chroma is None and np.array_equal(lean.lightness, planes.lightness)
    assert ver.lightness_features(color, impurity, objects & ~impurity, lean) == \
        ver.lightness_features(color, impurity, objects & ~impurity)


def test_a_model_naming_an_unknown_feature_or_too_few_values_is_refused():
    with pytest.raises(ValueError, match="features must be distinct names of ALL_FEATURES"):
        ver.RegionVerifier(mean=(0.0,), scale=(1.0,), coef=(0.0,), intercept=0.0, **THRESHOLDS, low=(0.0,),
                           high=(1.0,), features=("colour_contrast_typo",))
    with pytest.raises(ValueError, match=r"RegionVerifier.coef needs 2 values \(colour_contrast, rank\)"):
        ver.RegionVerifier(mean=(0.0, 0.0), scale=(1.0, 1.0), coef=(0.0,), intercept=0.0, **THRESHOLDS,
                           low=(0.0, 0.0), high=(1.0, 1.0), features=("colour_contrast", "rank"))


def tilted_view(odd=None, size=72, block=12):
    """Product blocks each tilted along x by a random slope and shaded by it (lighter when tilted towards +x,
    as under a light from there), one block (the first of the third row) in `odd`'s colour if given.
    Returns (color, height, objects, that block, another product block)."""
    rng = np.random.default_rng(2)
    color = np.zeros((size, size, 3), np.uint8)
    height = np.zeros((size, size), np.float32)
    odd_block, product_block = np.zeros((size, size), bool), np.zeros((size, size), bool)
    for row in range(0, size, block):
        for col in range(0, size, block):
            cells = (slice(row + 1, row + block - 1), slice(col + 1, col + block - 1))
            slope = rng.uniform(-0.0015, 0.0015)  # m per 2 mm cell
            height[cells] = 0.03 + slope * (np.arange(block - 2)[None, :] - (block - 3) / 2)
            shade = np.array((40, 120, 200)) * (1.0 + 250 * slope) * rng.uniform(0.98, 1.02)
            color[cells] = np.clip(shade, 0, 255)
            if (row, col) == (2 * block, 0):
                odd_block[cells] = True
                if odd is not None:
                    color[cells] = odd
            elif (row, col) == (block, block):
                product_block[cells] = True
    return color, height, height > 0.008, odd_block, product_block


def features_of(color, height, objects, cells):
    values = ver.region_features(color, height, objects, conspicuity_of(color, objects), cells)
    return dict(zip(ver.REGION_FEATURES, values, strict=True))


def test_an_impurity_stands_apart_from_product_faces_of_its_orientation_and_a_product_face_does_not():
    color, height, objects, odd, product = tilted_view(odd=(200, 60, 40))
    impurity = features_of(color, height, objects, odd)
    ordinary = features_of(color, height, objects, product)
    assert impurity["oriented_contrast"] > 2.0 and impurity["oriented_off_share"] > 0.9
    assert ordinary["oriented_contrast"] < 1.0 and ordinary["oriented_off_share"] < 0.1
    assert abs(ordinary["oriented_lightness"]) < 1.0


def unknown(values) -> bool:
    return all(np.isnan(value) for value in values)


def test_too_few_product_cells_leave_the_oriented_features_unknown():
    color, height, objects, tilted, _ = tilted_view()
    product = np.zeros_like(objects)
    product[0, :ver.ORIENTED_MIN_PRODUCT - 1] = True
    assert unknown(ver.oriented_features(color, height, tilted, product))


def test_a_product_clipped_in_every_channel_leaves_the_oriented_features_unknown():
    """A white-clipped product (a light product at a long exposure) says nothing about orientation."""
    color, height, objects, odd, _ = tilted_view(odd=(120, 120, 120))
    color[objects & ~odd] = 255
    assert unknown(ver.oriented_features(color, height, odd, objects & ~odd))


def test_faces_clipped_in_some_channels_are_still_read():
    """A blue product's lit faces clipped in green and blue keep their red: still a function of the normal."""
    color, height, objects, odd, product = tilted_view(odd=(200, 60, 40))
    clipped = color.copy()
    clipped[objects & ~odd, 1:] = 255
    impurity = ver.oriented_features(clipped, height, odd, objects & ~odd)
    assert np.all(np.isfinite(impurity))
    assert impurity[0] > 2.0 and impurity[2] > 0.9


def test_a_model_reads_an_unknown_feature_as_its_fitted_mean():
    names = ("colour_contrast", "oriented_contrast")
    model = ver.RegionVerifier(mean=(1.0, 1.5), scale=(0.5, 0.6), coef=(1.0, 2.0), intercept=0.0,
                               **THRESHOLDS, low=(0.0, 0.0), high=(3.0, 4.0), features=names)
    row = np.zeros((1, len(ver.FEATURES)))
    row[0, ver.FEATURES.index("colour_contrast")] = 2.0
    at_mean, unknown_row, as_product = row.copy(), row.copy(), row.copy()
    at_mean[0, ver.FEATURES.index("oriented_contrast")] = 1.5
    unknown_row[0, ver.FEATURES.index("oriented_contrast")] = np.nan
    assert model.probability(unknown_row)[0] == pytest.approx(model.probability(at_mean)[0])
    assert model.probability(unknown_row)[0] == pytest.approx(1.0 / (1.0 + np.exp(-2.0)))
    assert model.probability(as_product)[0] < 0.1  # 0 would read as "like the product"


def test_a_flat_face_has_no_height_spread_and_a_step_has():
    color, height, objects, impurity, _ = two_colour_view()
    maps = conspicuity_of(color, objects)
    flat = ver.region_features(color, height, objects, maps, impurity)
    stepped = height.copy()
    stepped[impurity & (np.arange(height.shape[1])[None, :] < 6)] = 0.05
    step = ver.region_features(color, stepped, objects, maps, impurity)
    index = ver.FEATURES.index("height_spread")
    assert flat[index] == pytest.approx(0.0, abs=1e-6)
    assert step[index] == pytest.approx(0.01, abs=0.002)


def test_hue_rarity_and_shape_features_do_not_move_with_exposure():
    # colour_contrast does: its least spread is in RGB (module docstring); the decision's invariance is
    # test_attention_palettes.test_brightness_leaves_the_decision_unchanged
    color, height, objects, impurity, _ = two_colour_view()
    darker = (color.astype(np.float32) * 0.5 + 0.5).astype(np.uint8)
    reference = ver.region_features(color, height, objects, conspicuity_of(color, objects), impurity)
    scaled = ver.region_features(darker, height, objects, conspicuity_of(darker, objects), impurity)
    assert scaled[1:] == pytest.approx(reference[1:], rel=0.1, abs=0.05)
    assert len(reference) == len(ver.REGION_FEATURES)


def test_the_shipped_model_rates_a_colour_distinct_region_above_a_product_coloured_one():
    color, height, objects, impurity, product = two_colour_view()
    maps = conspicuity_of(color, objects)
    model = ver.default_verifier()
    network = shipped_network() if model.reads_network else None  # read as attend reads it
    candidates = ver.candidate_features(color, height, objects, maps,
                                        [region(impurity, 2.0), region(product, 2.0)], network=network)
    odd, same = model.probability(np.array([features for _, features in candidates]))
    assert odd >= model.threshold > same


def test_the_shipped_model_says_where_it_comes_from():
    model = ver.default_verifier()
    assert "impurity_learning.calibrate verifier" in model.provenance and "tuning" in model.provenance
    assert 0.0 < model.threshold < 1.0


@pytest.mark.parametrize("field, value, named", [
    ("coef", (1.0, 2.0), "coef"),
    ("mean", (0.0,) * 6, "mean"),
    ("scale", (1.0, 1.0, 0.0) + (1.0,) * (len(ver.FEATURES) - 3), "scale"),
    ("low", (1e9,) * len(ver.FEATURES), "low"),
    ("threshold", 1.0, "threshold"),
])
def test_a_malformed_model_is_refused_by_name(field, value, named):
    with pytest.raises(ValueError, match=named):
        dataclasses.replace(ver.default_verifier(), **{field: value})


def test_attention_takes_the_likeliest_region_and_says_why():
    color, height, _, impurity, _ = two_colour_view()
    output = att.attend(color, height, att.AttentionParams())
    assert output.mode == att.AttentionMode.TARGET, output.reason
    assert "impurity probability" in output.reason
    assert np.count_nonzero(output.target_mask & impurity) > 0.5 * np.count_nonzero(output.target_mask)


def test_a_view_of_product_only_gives_no_target_with_the_likeliest_probability():
    color, height, *_ = two_colour_view(impurity=(40, 120, 200))
    output = att.attend(color, height, att.AttentionParams())
    assert output.mode != att.AttentionMode.TARGET
    assert "no salient region is an impurity: the likeliest, region" in output.reason


def test_the_models_threshold_decides():
    # a model that rates every region 0.5, with its own threshold 0.6
    n = len(ver.FEATURES)
    coin = ver.RegionVerifier(mean=(0.0,) * n, scale=(1.0,) * n, coef=(0.0,) * n, intercept=0.0,
                              threshold=0.6, last_look=0.99, stall_look=0.2, low=(-1e9,) * n, high=(1e9,) * n)
    color, height, *_ = two_colour_view()
    own = att.attend(color, height, att.AttentionParams(verifier=coin))  # no last look at 0.5
    assert own.mode != att.AttentionMode.TARGET and "0.50 < 0.60" in own.reason
    lower = dataclasses.replace(coin, threshold=0.4)
    lowered = att.attend(color, height, att.AttentionParams(verifier=lower))
    assert lowered.mode == att.AttentionMode.TARGET and "0.50 >= 0.40" in lowered.reason




def test_a_model_survives_its_file(tmp_path):
    shipped = ver.default_verifier()
    ver.write_verifier(shipped, tmp_path / "verifier.json")
    assert ver.read_verifier(tmp_path / "verifier.json") == shipped


def test_the_shipped_model_is_the_file_beside_the_network():
    assert ver.default_verifier() == ver.read_verifier(ver.SOURCE_VERIFIER)
    assert ver.default_verifier().features == ver.ALL_FEATURES


def test_the_shipped_models_probabilities_are_its_formula():
    model = ver.default_verifier()
    rng = np.random.default_rng(0)
    rows = rng.uniform(np.array(model.low) - 1.0, np.array(model.high) + 1.0, (5, len(model.features)))
    z = (np.clip(rows, model.low, model.high) - np.array(model.mean)) / np.array(model.scale)
    expected = 1.0 / (1.0 + np.exp(-(z @ np.array(model.coef) + model.intercept)))
    np.testing.assert_allclose(model.probability(rows), expected, rtol=1e-12)


@pytest.mark.parametrize("change, named", [
    (lambda fields: fields.pop("stall_look"), "missing: stall_look"),
    (lambda fields: fields.update(bias=1.0), "unknown: bias"),
    (lambda fields: fields.update(threshold=1.5), "threshold"),
])
def test_a_model_file_that_is_not_a_model_is_refused_naming_the_file_and_field(tmp_path, change, named):
    fields = dataclasses.asdict(ver.default_verifier())
    change(fields)
    path = tmp_path / "verifier.json"
    path.write_text(json.dumps(fields))
    with pytest.raises(ValueError, match=named) as refused:
        ver.read_verifier(path)
    assert str(path) in str(refused.value)


def test_the_installed_model_is_the_source_trees():
    from impurity_attention.core.checkpoints import shipped_path

    path = shipped_path(ver.SHIPPED_VERIFIER)
    assert path.is_file() and path.read_text() == ver.SOURCE_VERIFIER.read_text()
