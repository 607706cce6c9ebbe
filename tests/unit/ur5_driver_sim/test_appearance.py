"""Palettes: validation names the bad field, names resolve or are refused with the list, random palettes
are seeded and keep their impurities distinguishable, and a scene keeps its layout under every palette
while the default palette draws config.py's product and impurity colours."""

import numpy as np
import pytest

from ur5_driver_sim.core import appearance, config
from ur5_driver_sim.core.world import CellWorld


def palette(**changes):
    fields = dict(name="test", product_shades=((0.2, 0.3, 0.4),), impurity_colors=((0.8, 0.2, 0.1),))
    fields.update(changes)
    return appearance.Palette(**fields)


@pytest.mark.parametrize("field, value", [
    ("product_shades", ()), ("product_shades", ((0.2, 0.3),)), ("impurity_colors", ((1.5, 0.0, 0.0),)),
    ("impurity_colors", ((float("nan"), 0.0, 0.0),)), ("product_jitter", -0.1), ("ambient", 3.0),
    ("diffuse", float("inf")), ("exposure", 0.0), ("light_direction", (0.0, 0.0, -1.0)),
    ("light_direction", (0.0, 0.0))])
def test_a_bad_palette_field_is_named(field, value):
    with pytest.raises(ValueError, match=field):
        palette(**{field: value})


def test_named_palettes_resolve_and_the_empty_name_is_the_default():
    assert appearance.palette_named("") is appearance.PALETTES["blocks"]
    assert appearance.palette_named("coal_slate").name == "coal_slate"
    assert len(appearance.PALETTES) >= 6


def test_an_unknown_palette_is_refused_with_the_known_names():
    with pytest.raises(ValueError) as refused:
        appearance.palette_named("marble")
    message = str(refused.value)
    assert "marble" in message and "coal_slate" in message and "random-<seed>" in message


def test_exposure_suffix_changes_only_the_exposure():
    darker = appearance.palette_named("blocks@x0.5")
    assert darker.exposure == 0.5 and darker.product_shades == appearance.PALETTES["blocks"].product_shades
    image = np.full((2, 2, 3), 200, np.uint8)
    assert darker.expose(image)[0, 0, 0] == 100
    assert appearance.palette_named("blocks@x2").expose(image)[0, 0, 0] == 255  # saturates


def test_a_product_jitter_suffix_changes_only_the_products_spread_and_combines_with_exposure():
    wide = appearance.palette_named("random-800@j0.05")
    base = appearance.random_palette(800)
    assert wide.product_jitter == 0.05 and wide.name == "random-800@j0.05"
    assert (wide.product_shades, wide.impurity_colors, wide.exposure) == \
        (base.product_shades, base.impurity_colors, base.exposure)
    both = appearance.palette_named("random-800@j0.05@x0.5")
    assert both.product_jitter == 0.05 and both.exposure == 0.5
    with pytest.raises(ValueError, match="product_jitter"):
        appearance.palette_named("blocks@j0.5")  # beyond the field's range


def test_random_palettes_are_seeded_and_keep_impurities_distinguishable():
    assert appearance.palette_named("random-7") == appearance.random_palette(7)
    assert appearance.random_palette(7) != appearance.random_palette(8)
    for seed in range(30):
        generated = appearance.random_palette(seed)
        assert 1 <= len(generated.impurity_colors) <= 2 and 1 <= len(generated.product_shades) <= 3
        assert generated.min_impurity_delta_e() >= appearance.RANDOM_IMPURITY_DELTA_E[0] - 0.5


LIGHTNESS_SEEDS = range(60)


def test_lightness_palettes_are_seeded_and_addressed_by_name():
    assert appearance.palette_named("lightness-7") == appearance.lightness_palette(7)
    assert appearance.palette_named("lightness-7@x1.2").exposure == 1.2
    assert appearance.lightness_palette(7) != appearance.lightness_palette(8)
    assert appearance.lightness_palette(7).name == "lightness-7"


@pytest.mark.parametrize("seed", LIGHTNESS_SEEDS)
def test_a_lightness_palettes_impurities_differ_from_the_product_mainly_in_lightness(seed):
    generated = appearance.lightness_palette(seed)
    base = generated.product_shades[0]
    assert 1 <= len(generated.impurity_colors) <= 2 and 1 <= len(generated.product_shades) <= 3
    assert all(appearance.delta_e(shade, base) <= appearance.RANDOM_SHADE_DELTA_E + 0.5
               for shade in generated.product_shades)
    low, high = appearance.LIGHTNESS_DELTA_E
    for impurity in generated.impurity_colors:
        assert low <= appearance.delta_e(impurity, base) <= high
        assert generated.min_impurity_delta_e() >= low
        assert appearance.chroma_shift(impurity, base) <= appearance.LIGHTNESS_MAX_CHROMA_SHIFT


def test_lightness_palettes_are_darker_and_lighter_at_normal_and_bright_exposure_unclipped_where_lit():
    palettes = [appearance.lightness_palette(seed) for seed in LIGHTNESS_SEEDS]
    lighter = [appearance.delta_e(i, (0, 0, 0)) > appearance.delta_e(p.product_shades[0], (0, 0, 0))
               for p in palettes for i in p.impurity_colors]
    assert 0.25 < np.mean(lighter) < 0.75
    exposures = np.array([p.exposure for p in palettes])
    assert exposures.min() >= appearance.LIGHTNESS_EXPOSURE[0]
    assert exposures.max() <= appearance.LIGHTNESS_BRIGHT_EXPOSURE[1]
    assert 0.1 < np.mean(exposures > appearance.LIGHTNESS_EXPOSURE[1]) < 0.4
    for p in palettes:
        brightest = max(max(c) for c in p.product_shades + p.impurity_colors)
        assert brightest * (p.ambient + p.diffuse) * p.exposure <= appearance.LIGHTNESS_CEILING + 1e-6


def test_default_palette_draws_the_configured_product_colours():
    """Product blocks take base + uniform(-jitter, jitter) per channel from the layout generator."""
    colours = appearance.PALETTES["blocks"].colours(scene_seed=4)
    drawn = colours.product(np.random.default_rng(11))
    layout_rng = np.random.default_rng(11)
    jitter = config.PRODUCT_SHADE_JITTER
    expected = tuple(float(np.clip(c + layout_rng.uniform(-jitter, jitter), 0.0, 1.0))
                     for c in config.PRODUCT_COLOR)
    assert drawn == expected
    assert colours.impurity() == config.TARGET_COLOR


@pytest.fixture(scope="module")
def world():
    w = CellWorld(mode="floating")
    yield w
    w.close()


def test_a_seed_gives_the_same_layout_under_every_palette(world):
    layouts, colours = [], []
    for name in ("", "mushrooms_stones", "random-3"):
        info = world.reset_scene("random", seed=21, palette=name)
        assert info.palette == (name or "blocks")
        layouts.append(np.array([world.pb.getBasePositionAndOrientation(b)[0] for b in info.target_ids]))
        colours.append(world.specs[info.target_ids[0]].color)
    assert np.allclose(layouts[0], layouts[1]) and np.allclose(layouts[0], layouts[2])
    assert len(set(colours)) == 3


def test_exposure_darkens_the_rendered_image(world):
    world.reset_scene("random", seed=2, palette="blocks")
    bright = world.render().color.astype(float).mean()
    world.reset_scene("random", seed=2, palette="blocks@x0.5")
    assert world.render().color.astype(float).mean() == pytest.approx(bright / 2, rel=0.03)


def test_reset_scene_refuses_an_unknown_palette_before_building(world):
    with pytest.raises(ValueError, match="unknown palette"):
        world.reset_scene("random", seed=1, palette="granite")
