"""The palettes file (ur5_driver_sim/data/palettes.yaml): the shipped file loads, and every kind of bad
entry is refused with a message naming the file, the palette and the field."""

import copy

import pytest
import yaml

from ur5_driver_sim.core import appearance
from ur5_driver_sim.core.appearance import PaletteFileError, load_palettes

GOOD = {"name": "coal_slate", "split": "tuning", "description": "coal with slate",
        "product_shades": [[38, 36, 36], [30, 30, 32]], "impurity_colours": [[78, 82, 92]],
        "product_jitter": 0.015, "impurity_jitter": 0.02,
        "light": {"direction": [0.3, 0.2, 1.0], "ambient": 0.6, "diffuse": 0.45}, "exposure": 1.0}
DEFAULT = {**GOOD, "name": "blocks", "split": "default", "product_shades": [[40, 120, 200]],
           "impurity_colours": [[220, 60, 40]]}


def write(tmp_path, *entries, document=None):
    path = tmp_path / "palettes.yaml"
    path.write_text(yaml.safe_dump(document if document is not None else {"palettes": list(entries)}))
    return path


def refusal(tmp_path, **changes) -> str:
    entry = copy.deepcopy(GOOD)
    for field, value in changes.items():
        if value is None:
            del entry[field]
        else:
            entry[field] = value
    with pytest.raises(PaletteFileError) as refused:
        load_palettes(write(tmp_path, DEFAULT, entry))
    return str(refused.value)


def test_the_shipped_file_loads_every_palette_with_its_split():
    palettes, splits = load_palettes()
    assert palettes == appearance.PALETTES and splits == appearance.PALETTE_SPLITS
    assert list(palettes)[0] == "blocks" and splits["blocks"] == "default"
    assert set(splits.values()) <= set(appearance.SPLITS)
    assert {"tuning", "held_out"} <= set(splits.values())


def test_the_default_palette_is_the_cells_blue_product_with_red_impurities():
    from ur5_driver_sim.core import config
    blocks = appearance.PALETTES["blocks"]
    assert blocks.product_shades == (config.PRODUCT_COLOR,)
    assert blocks.impurity_colors == (config.TARGET_COLOR,)
    assert blocks.product_jitter == config.PRODUCT_SHADE_JITTER and blocks.impurity_jitter == 0.0


def test_a_good_file_gives_palettes_in_0_1_and_their_splits(tmp_path):
    palettes, splits = load_palettes(write(tmp_path, DEFAULT, GOOD))
    assert list(palettes) == ["blocks", "coal_slate"]
    assert splits == {"blocks": "default", "coal_slate": "tuning"}
    coal = palettes["coal_slate"]
    assert coal.product_shades[0] == (38 / 255, 36 / 255, 36 / 255)
    assert coal.light_direction == (0.3, 0.2, 1.0)


@pytest.mark.parametrize("colours", [[[78, 82, 92], [12, 300, 4]], [[78, 82, 92], [12, 4]],
                                     [[78, 82, 92], ["a", 1, 2]]])
def test_a_bad_impurity_colour_names_the_palette_field_and_index(tmp_path, colours):
    message = refusal(tmp_path, impurity_colours=colours)
    assert message.startswith("palettes.yaml: palette 'coal_slate': impurity_colours[1]: expected 3 numbers "
                              "in 0..255, got ")


def test_the_message_shows_the_bad_value(tmp_path):
    assert refusal(tmp_path, impurity_colours=[[78, 82, 92], [12, 300, 4]]) == \
        ("palettes.yaml: palette 'coal_slate': impurity_colours[1]: expected 3 numbers in 0..255, "
         "got [12, 300, 4]")


def test_no_product_shade_is_refused(tmp_path):
    assert "palette 'coal_slate': product_shades: expected a list" in refusal(tmp_path, product_shades=[])


def test_a_missing_field_is_named(tmp_path):
    assert "palette 'coal_slate': missing exposure" in refusal(tmp_path, exposure=None)


def test_an_unknown_field_is_named(tmp_path):
    assert "unknown field colour" in refusal(tmp_path, colour=[1, 2, 3])


def test_an_unknown_split_is_named(tmp_path):
    assert "palette 'coal_slate': split: expected one of default, tuning, held_out, spare, got 'test'" in \
        refusal(tmp_path, split="test")


@pytest.mark.parametrize("field, value, named", [
    ("exposure", 0.0, "exposure"), ("exposure", "bright", "exposure"),
    ("product_jitter", 0.5, "product_jitter"),
    ("impurity_jitter", -0.1, "impurity_jitter"),
    ("light", {"direction": [0, 0, -1], "ambient": 0.6, "diffuse": 0.45}, "light_direction"),
    ("light", {"direction": [0, 1], "ambient": 0.6, "diffuse": 0.45}, "light.direction"),
    ("light", {"direction": [0, 0, 1], "ambient": 3.0, "diffuse": 0.45}, "ambient"),
    ("light", {"direction": [0, 0, 1], "ambient": 0.6}, "light"),
    ("description", 7, "description")])
def test_a_value_out_of_range_names_the_palette_and_field(tmp_path, field, value, named):
    message = refusal(tmp_path, **{field: value})
    assert message.startswith("palettes.yaml: palette 'coal_slate': ") and named in message


def test_a_name_listed_twice_is_refused(tmp_path):
    with pytest.raises(PaletteFileError, match="palette 'coal_slate': name: listed twice"):
        load_palettes(write(tmp_path, DEFAULT, GOOD, GOOD))


@pytest.mark.parametrize("name", ["Coal", "random_800", "", 12])
def test_a_bad_name_is_refused_by_position(tmp_path, name):
    with pytest.raises(PaletteFileError, match=r"palettes\[1\]: name"):
        load_palettes(write(tmp_path, DEFAULT, {**GOOD, "name": name}))


def test_exactly_one_default_palette_is_required(tmp_path):
    with pytest.raises(PaletteFileError, match="exactly one palette, 'blocks'"):
        load_palettes(write(tmp_path, GOOD))
    with pytest.raises(PaletteFileError, match="exactly one palette, 'blocks'"):
        load_palettes(write(tmp_path, DEFAULT, {**GOOD, "split": "default"}))


@pytest.mark.parametrize("document", [{}, {"palettes": []}, ["blocks"], {"palettes": ["blocks"]}])
def test_a_file_of_the_wrong_shape_is_refused(tmp_path, document):
    with pytest.raises(PaletteFileError, match="palettes.yaml"):
        load_palettes(write(tmp_path, document=document))


def test_a_file_that_is_not_yaml_is_refused(tmp_path):
    path = tmp_path / "palettes.yaml"
    path.write_text("palettes: [\n")
    with pytest.raises(PaletteFileError, match="palettes.yaml: not YAML"):
        load_palettes(path)
