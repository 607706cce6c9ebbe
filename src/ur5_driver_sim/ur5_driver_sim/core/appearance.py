"""What a simulated scene looks like: product and impurity colours, light and camera exposure (issue 17).

The cell's promise (paper sections 1 and 5.1.1) is that nobody tells it what the impurities look like,
so the simulator renders the same layouts under many appearances:

- `Palette`: the product's colour distribution (one or several base shades, a per-block jitter), the
  impurity colours (one or several per scene; they may be close to the product), the light (direction,
  ambient and diffuse strength of PyBullet's TinyRenderer) and the camera's exposure (a factor on the
  rendered RGB, clipped to 255 like a saturating sensor).
- `PALETTES`: named palettes modelled on real sorting jobs, plus `random_palette(seed)`, addressed by
  name as `random-<seed>`. `palette_named(name)` refuses an unknown name with the list of known ones.
- `BlockColours`: the per-scene colour draw. Product blocks take their jitter from the layout's random
  generator exactly as before palettes existed (so the default palette renders the scenes of earlier
  releases bit for bit); the choice of shade and impurity colour comes from a second generator seeded
  by the scene seed, so one seed gives the same layout under every palette.

Colours are RGB in [0, 1] (PyBullet's rgbaColor); `delta_e` is the CIE76 distance in CIE Lab (OpenCV's
float Lab, L in [0, 100]), the usual measure of "how different do two colours look".
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import cv2
import numpy as np

from . import config

LEGACY_JITTER = config.PRODUCT_SHADE_JITTER  # the layout rng draws uniform(-this, this) per channel
RANDOM_PREFIX = "random-"
DEFAULT_PALETTE = "blocks"
DEFAULT_LIGHT_DIRECTION = (0.3, 0.2, 1.0)
DEFAULT_AMBIENT = 0.6
DEFAULT_DIFFUSE = 0.45
# random palettes: how far (CIE76 Delta E) an impurity lies from the product's mean shade. 12 is about
# what a sorting operator calls "clearly different" on a matte surface; 60 is red among blue.
RANDOM_IMPURITY_DELTA_E = (12.0, 60.0)
RANDOM_SHADE_DELTA_E = 4.0  # at most this between a random palette's product shades
COLOUR_SEED_SALT = 0x5EED_C010  # the colour generator's seed: scene seed XOR this


def _rgb(values) -> tuple:
    return tuple(float(v) / 255.0 for v in values)


def delta_e(a, b) -> float:
    """CIE76 colour difference of two RGB colours in [0, 1] (Lab via OpenCV, D65)."""
    pixels = np.array([[a, b]], dtype=np.float32)
    lab = cv2.cvtColor(pixels, cv2.COLOR_RGB2Lab)[0]
    return float(np.linalg.norm(lab[0] - lab[1]))


@dataclass(frozen=True)
class Palette:
    """One appearance. Raises ValueError naming the bad field when a value is out of range."""

    name: str
    product_shades: tuple  # ((r, g, b), ...) in [0, 1]: each product block takes one of these
    impurity_colors: tuple  # ((r, g, b), ...) in [0, 1]: each impurity takes one of these
    product_jitter: float = LEGACY_JITTER  # +- per channel and block
    impurity_jitter: float = 0.02  # +- per channel and block
    light_direction: tuple = DEFAULT_LIGHT_DIRECTION  # towards the light, base_link, any length > 0
    ambient: float = DEFAULT_AMBIENT  # TinyRenderer ambient coefficient
    diffuse: float = DEFAULT_DIFFUSE  # TinyRenderer diffuse coefficient
    exposure: float = 1.0  # factor on the rendered RGB (0.5: one stop darker), clipped at 255
    description: str = ""

    def __post_init__(self):
        for field_name in ("product_shades", "impurity_colors"):
            colours = getattr(self, field_name)
            if not colours:
                raise ValueError(f"palette {self.name!r}: {field_name} needs at least one colour")
            for colour in colours:
                if len(colour) != 3 or not all(math.isfinite(c) and 0.0 <= c <= 1.0 for c in colour):
                    raise ValueError(f"palette {self.name!r}: {field_name} holds {colour}; "
                                     f"expected (r, g, b) in [0, 1]")
        for field_name, low, high in (("product_jitter", 0.0, 0.2), ("impurity_jitter", 0.0, 0.2),
                                      ("ambient", 0.0, 1.5), ("diffuse", 0.0, 1.5), ("exposure", 0.05, 8.0)):
            value = getattr(self, field_name)
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(f"palette {self.name!r}: {field_name} = {value} is outside [{low}, {high}]")
        direction = self.light_direction
        if len(direction) != 3 or not all(math.isfinite(v) for v in direction) or \
                math.hypot(*direction) < 1e-6 or direction[2] <= 0.0:
            raise ValueError(f"palette {self.name!r}: light_direction = {direction}; expected a finite "
                             f"(x, y, z) with z > 0 (the light is above the table)")

    def with_exposure(self, exposure: float) -> Palette:
        return replace(self, name=f"{self.name}@x{exposure:g}", exposure=float(exposure))

    def with_product_jitter(self, jitter: float) -> Palette:
        """The same appearance with each product block's colour spread +- `jitter` per channel (0..1 scale):
        a product whose pieces vary more (or less) around its shades."""
        return replace(self, name=f"{self.name}@j{jitter:g}", product_jitter=float(jitter))

    def colours(self, scene_seed: int) -> BlockColours:
        return BlockColours(self, scene_seed)

    def min_impurity_delta_e(self) -> float:
        """The smallest Delta E between an impurity colour and a product shade (how hard the job is)."""
        return min(delta_e(i, p) for i in self.impurity_colors for p in self.product_shades)

    def expose(self, rgb: np.ndarray) -> np.ndarray:
        """Apply the exposure to a rendered (H, W, 3) uint8 image (a saturating sensor)."""
        if self.exposure == 1.0:
            return rgb
        return np.clip(rgb.astype(np.float32) * np.float32(self.exposure) + 0.5, 0, 255).astype(np.uint8)

    def to_json(self) -> dict:
        return {"name": self.name, "product_shades": [list(c) for c in self.product_shades],
                "impurity_colors": [list(c) for c in self.impurity_colors],
                "product_jitter": self.product_jitter, "impurity_jitter": self.impurity_jitter,
                "light_direction": list(self.light_direction), "ambient": self.ambient,
                "diffuse": self.diffuse, "exposure": self.exposure}


class BlockColours:
    """The colour draw of one scene (see the module docstring for which generator draws what)."""

    def __init__(self, palette: Palette, scene_seed: int):
        self.palette = palette
        self.rng = np.random.default_rng(int(scene_seed) ^ COLOUR_SEED_SALT)

    def product(self, layout_rng: np.random.Generator) -> tuple:
        """A product block's colour; draws 3 uniforms from `layout_rng` (as the legacy jitter did)."""
        noise = [layout_rng.uniform(-LEGACY_JITTER, LEGACY_JITTER) for _ in range(3)]
        shades = self.palette.product_shades
        base = shades[self.rng.integers(len(shades))] if len(shades) > 1 else shades[0]
        scale = self.palette.product_jitter / LEGACY_JITTER
        return tuple(float(np.clip(c + n * scale, 0.0, 1.0))
                     for c, n in zip(base, noise, strict=True))

    def impurity(self) -> tuple:
        colours = self.palette.impurity_colors
        base = colours[self.rng.integers(len(colours))] if len(colours) > 1 else colours[0]
        jitter = self.palette.impurity_jitter
        if jitter <= 0.0:
            return tuple(base)
        return tuple(float(np.clip(c + self.rng.uniform(-jitter, jitter), 0.0, 1.0)) for c in base)


def _palette(name, product, impurities, description, **kwargs) -> Palette:
    return Palette(name=name, product_shades=tuple(_rgb(c) for c in product),
                   impurity_colors=tuple(_rgb(c) for c in impurities), description=description, **kwargs)


# Named palettes, modelled on real sorting jobs. Colours are sRGB 0..255 as a camera sees them under
# the cell's light; jitter is per channel (0..1 scale).
PALETTES = {p.name: p for p in (
    Palette(name="blocks", product_shades=(config.PRODUCT_COLOR,), impurity_colors=(config.TARGET_COLOR,),
            impurity_jitter=0.0, description="our blue product blocks with red impurities (the default)"),
    _palette("coal_slate", [(38, 36, 36), (30, 30, 32), (46, 43, 41)], [(78, 82, 92)],
             "near-black coal with slightly lighter blue-grey slate", product_jitter=0.015),
    _palette("mushrooms_stones", [(226, 212, 184), (214, 198, 168)], [(128, 126, 122), (108, 104, 100)],
             "light cream mushrooms with grey stones", product_jitter=0.02),
    _palette("beans_stones", [(120, 72, 44), (104, 62, 38), (134, 84, 52)], [(62, 60, 58)],
             "brown beans of several shades with dark stones", product_jitter=0.02),
    _palette("plastic_flakes", [(176, 204, 222), (190, 214, 228)], [(72, 150, 84), (206, 96, 64)],
             "pale blue PET flakes with foreign green and orange flakes", product_jitter=0.02,
             light_direction=(-0.4, 0.3, 1.0), ambient=0.55, diffuse=0.5),
    _palette("almonds_shells", [(160, 104, 66), (150, 96, 60)], [(196, 166, 124)],
             "almond kernels with lighter shell pieces", product_jitter=0.02,
             light_direction=(0.1, -0.5, 1.0)),
    _palette("peas_stones", [(96, 150, 64), (84, 140, 56)], [(150, 140, 120)],
             "green peas with light stones", product_jitter=0.02, ambient=0.5, diffuse=0.55),
    _palette("rice_husks", [(232, 228, 214)], [(186, 150, 92)],
             "white rice with yellow-brown husks", product_jitter=0.015, exposure=0.8),
    _palette("wood_plastic", [(172, 128, 84), (186, 140, 94), (160, 118, 76)], [(64, 98, 160)],
             "wood chips with blue plastic pieces", product_jitter=0.025,
             light_direction=(0.5, 0.5, 1.0), ambient=0.65, diffuse=0.4),
    # Added 2026-11-30 (fifth session) as the new held-out set, fixed before any of them was rendered.
    _palette("coffee_stones", [(74, 48, 34), (88, 58, 40), (64, 42, 30)], [(132, 128, 120)],
             "roasted coffee beans of several shades with grey stones", product_jitter=0.02,
             light_direction=(-0.3, -0.4, 1.0), ambient=0.6, diffuse=0.45),
    _palette("walnuts_shells", [(196, 160, 108), (182, 146, 96)], [(122, 86, 54)],
             "light walnut kernels with darker shell fragments", product_jitter=0.02,
             light_direction=(0.6, -0.2, 1.0)),
    _palette("glass_ceramic", [(96, 140, 96), (110, 156, 108)], [(214, 210, 200), (150, 92, 48)],
             "green glass cullet with white ceramic and brown glass", product_jitter=0.02, exposure=1.2),
    _palette("cranberries_leaves", [(150, 30, 40), (128, 24, 36), (168, 40, 48)],
             [(84, 110, 52), (110, 84, 50)],
             "red cranberries of several shades with green leaves and brown stems", product_jitter=0.02,
             ambient=0.5, diffuse=0.55, exposure=0.85),
    # Added 2026-11-30 (sixth session) as the third held-out set, fixed before any of them was rendered.
    _palette("lentils_stones", [(214, 120, 64), (200, 108, 56), (226, 132, 72)], [(118, 112, 104)],
             "red lentils of several shades with grey stones", product_jitter=0.02,
             light_direction=(0.2, 0.5, 1.0), ambient=0.55, diffuse=0.5),
    _palette("tea_stems", [(58, 54, 36), (48, 46, 30), (66, 60, 40)], [(150, 128, 84)],
             "dark tea leaves with light woody stems", product_jitter=0.015, exposure=1.1),
    _palette("pistachios_shells", [(132, 150, 70), (120, 140, 64)], [(204, 184, 150), (96, 70, 60)],
             "green pistachio kernels with beige shell fragments and dark husk", product_jitter=0.02,
             light_direction=(-0.5, 0.1, 1.0), ambient=0.65, diffuse=0.4),
    _palette("pvc_in_pet", [(200, 214, 220), (188, 204, 214)], [(236, 234, 226)],
             "clear PET flakes with opaque white PVC flakes", product_jitter=0.02, exposure=0.9),
    # Added 2026-12-01 (ninth session) as the fourth held-out set, fixed before any of them was rendered.
    _palette("hazelnuts_shells", [(180, 134, 88), (168, 122, 78)], [(92, 62, 44)],
             "blanched hazelnut kernels with dark shell fragments", product_jitter=0.02,
             light_direction=(0.3, -0.3, 1.0)),
    _palette("maize_stones", [(230, 184, 60), (218, 170, 50), (238, 196, 76)], [(132, 124, 112)],
             "yellow maize kernels of several shades with grey stones", product_jitter=0.02,
             ambient=0.55, diffuse=0.5),
    _palette("blueberries_stems", [(52, 56, 92), (44, 48, 80), (60, 62, 104)], [(112, 104, 62)],
             "dark blueberries of several shades with olive stems and leaves", product_jitter=0.015,
             light_direction=(-0.2, 0.5, 1.0), exposure=1.15),
    _palette("raisins_stems", [(70, 40, 40), (82, 48, 44)], [(150, 140, 80), (118, 92, 60)],
             "dark raisins with yellow-green and brown stems", product_jitter=0.02,
             ambient=0.6, diffuse=0.45),
    # Added 2026-12-01 (tenth session) as the fifth held-out set, fixed before any of them was rendered.
    _palette("chickpeas_stones", [(212, 176, 120), (200, 164, 108), (222, 188, 132)], [(120, 110, 98)],
             "beige chickpeas of several shades with grey-brown stones", product_jitter=0.02,
             light_direction=(0.4, 0.2, 1.0)),
    _palette("pumpkin_seeds_husks", [(84, 110, 62), (74, 100, 56)], [(206, 190, 140)],
             "green pumpkin seeds with pale husks", product_jitter=0.02, ambient=0.55, diffuse=0.5),
    _palette("black_beans_husks", [(36, 32, 36), (44, 38, 42)], [(112, 86, 62)],
             "black beans with brown husk pieces", product_jitter=0.015,
             light_direction=(-0.3, 0.3, 1.0), exposure=1.2),
    _palette("pp_flakes_rubber", [(170, 172, 176), (182, 184, 188)], [(44, 42, 42), (150, 60, 52)],
             "light grey polypropylene flakes with black rubber and red foreign flakes", product_jitter=0.02,
             ambient=0.6, diffuse=0.45, exposure=0.9),
    # Added 2026-12-01 (eleventh session) as the sixth held-out set, fixed before any of them was rendered.
    _palette("rice_paddy", [(236, 230, 214), (228, 222, 204)], [(164, 120, 70)],
             "white milled rice with brown unhulled paddy grains", product_jitter=0.015,
             light_direction=(0.2, 0.4, 1.0)),
    _palette("sunflower_seeds_stones", [(58, 58, 62), (72, 70, 70), (50, 50, 54)], [(168, 160, 148)],
             "dark grey sunflower seeds of several shades with light stones", product_jitter=0.02,
             ambient=0.55, diffuse=0.5),
    _palette("cocoa_beans_stones", [(112, 72, 52), (100, 64, 46)], [(126, 122, 116), (88, 84, 80)],
             "brown cocoa beans with grey stones, light and dark", product_jitter=0.02,
             light_direction=(-0.2, 0.3, 1.0)),
    _palette("hdpe_flakes_paper", [(226, 226, 220), (216, 218, 214)], [(198, 186, 154)],
             "white HDPE flakes with paper label scraps", product_jitter=0.015, exposure=1.1),
    # Added 2026-12-01 (twelfth session) as the seventh held-out set, fixed before any of them was rendered.
    _palette("cashews_shells", [(228, 208, 170), (218, 196, 156)], [(100, 72, 50)],
             "pale cashew kernels with dark brown shell pieces", product_jitter=0.015,
             light_direction=(-0.4, -0.2, 1.0)),
    _palette("green_coffee_stones", [(150, 160, 112), (138, 150, 102), (160, 168, 120)],
             [(72, 68, 62), (44, 40, 36)],
             "green coffee beans of several shades with grey stones and black beans", product_jitter=0.02,
             ambient=0.55, diffuse=0.5),
    _palette("flint_glass_amber", [(204, 216, 206), (192, 206, 196)], [(172, 102, 42), (120, 116, 110)],
             "clear flint glass cullet with amber glass and stones", product_jitter=0.02, exposure=1.1,
             light_direction=(0.5, 0.1, 1.0)),
    _palette("kidney_beans_stones", [(112, 38, 42), (98, 32, 38)], [(118, 114, 108)],
             "dark red kidney beans with grey stones", product_jitter=0.02, ambient=0.6, diffuse=0.45),
    # Added 2026-12-01 (thirteenth session) as the eighth held-out set, fixed before any of them was rendered.
    _palette("soybeans_stones", [(222, 196, 140), (210, 182, 124)], [(120, 112, 104)],
             "yellow soybeans with grey-brown stones", product_jitter=0.02, light_direction=(0.3, 0.4, 1.0)),
    _palette("macadamia_shells", [(236, 222, 190), (226, 208, 172)], [(122, 84, 56), (150, 110, 76)],
             "cream macadamia kernels with brown shell pieces, dark and light", product_jitter=0.015,
             exposure=1.05),
    _palette("red_lentils_stones", [(222, 120, 70), (210, 108, 62), (230, 132, 80)], [(140, 130, 120)],
             "orange-red lentils of several shades with grey stones", product_jitter=0.02, ambient=0.55,
             diffuse=0.5),
    _palette("barley_stones", [(214, 186, 120), (200, 170, 104)], [(96, 92, 88), (150, 140, 128)],
             "golden barley with dark and light stones", product_jitter=0.02,
             light_direction=(-0.3, 0.5, 1.0)),
    # Added 2026-12-02 (seventeenth session) as the ninth held-out set, fixed before any of them was rendered.
    _palette("peanuts_stones", [(206, 160, 112), (194, 148, 100)], [(112, 108, 104)],
             "blanched peanuts with grey stones", product_jitter=0.02, light_direction=(0.2, -0.4, 1.0)),
    _palette("quinoa_stones", [(230, 218, 192), (220, 206, 178)], [(140, 124, 108), (92, 86, 80)],
             "off-white quinoa with brown-grey and dark stones", product_jitter=0.015, exposure=0.95),
    _palette("pecans_shells", [(124, 80, 50), (112, 72, 44), (136, 90, 58)], [(176, 136, 96)],
             "brown pecan kernels of several shades with lighter shell pieces", product_jitter=0.02,
             ambient=0.55, diffuse=0.5),
    _palette("abs_flakes_metal", [(42, 42, 44), (54, 52, 52)], [(150, 152, 158)],
             "black ABS flakes with grey aluminium pieces", product_jitter=0.015,
             light_direction=(-0.2, -0.3, 1.0)),
    # Added 2026-12-03 (twenty-second session) as the tenth held-out set, fixed before any was rendered.
    _palette("sesame_stones", [(234, 220, 186), (226, 210, 172)], [(96, 90, 84)],
             "hulled sesame seeds with dark grey stones", product_jitter=0.015,
             light_direction=(0.4, -0.1, 1.0)),
    _palette("buckwheat_stones", [(150, 110, 70), (138, 100, 62), (162, 120, 80)], [(128, 126, 122)],
             "roasted buckwheat of several shades with grey stones", product_jitter=0.02,
             ambient=0.55, diffuse=0.5),
    _palette("mung_beans_stones", [(104, 140, 60), (94, 128, 54)], [(140, 120, 96), (70, 66, 60)],
             "green mung beans with brown and dark stones", product_jitter=0.02,
             light_direction=(-0.4, 0.4, 1.0), exposure=1.05),
    _palette("pa_flakes_wood", [(238, 236, 228), (228, 226, 218)], [(176, 130, 82)],
             "white nylon flakes with wood splinters", product_jitter=0.015, exposure=0.9),
    # Added 2026-12-03 (twenty-sixth session) as the eleventh held-out set, fixed before any was rendered.
    _palette("oat_groats_husks", [(196, 170, 122), (184, 158, 112)], [(224, 206, 148)],
             "light brown oat groats with pale straw husks", product_jitter=0.02,
             light_direction=(0.3, 0.3, 1.0)),
    _palette("black_pepper_stones", [(48, 40, 36), (58, 48, 42), (40, 34, 32)], [(126, 122, 116)],
             "black peppercorns of several shades with grey stones", product_jitter=0.015,
             ambient=0.55, diffuse=0.5, exposure=1.1),
    _palette("pine_nuts_shells", [(232, 214, 176), (222, 202, 162)], [(86, 60, 44)],
             "ivory pine nut kernels with dark brown shell pieces", product_jitter=0.015,
             light_direction=(-0.3, -0.3, 1.0)),
    _palette("pet_flakes_green", [(190, 208, 222), (178, 198, 214)], [(82, 150, 98), (160, 162, 168)],
             "clear blue-tinted PET flakes with green PET and aluminium pieces", product_jitter=0.02,
             exposure=0.95),
    # the twelfth held-out set (twenty-seventh session), named before any of it was rendered
    _palette("white_beans_stones", [(236, 230, 214), (226, 218, 200)], [(142, 130, 116)],
             "white navy beans with brownish-grey stones", product_jitter=0.015,
             light_direction=(0.2, -0.3, 1.0)),
    _palette("millet_stones", [(224, 196, 110), (212, 184, 100)], [(132, 130, 126)],
             "yellow millet of two shades with grey stones", product_jitter=0.02, exposure=1.05),
    _palette("cumin_seeds_stems", [(140, 116, 80), (128, 104, 72), (150, 126, 90)], [(196, 176, 128)],
             "brown cumin seeds of several shades with pale straw stems", product_jitter=0.015,
             ambient=0.5, diffuse=0.55),
    _palette("pp_flakes_black", [(232, 232, 226), (220, 222, 218)], [(40, 40, 42), (180, 50, 48)],
             "white PP flakes with black rubber and red PP pieces", product_jitter=0.02,
             light_direction=(-0.2, 0.3, 1.0)),
    # the thirteenth held-out set (twenty-ninth session), named before any of it was rendered
    _palette("adzuki_beans_stones", [(128, 40, 38), (116, 34, 34)], [(104, 92, 84)],
             "dark red adzuki beans of two shades with brown-grey stones", product_jitter=0.015,
             light_direction=(0.3, 0.2, 1.0)),
    _palette("sorghum_stones", [(196, 140, 96), (184, 128, 86), (206, 152, 106)], [(150, 146, 140)],
             "reddish-tan sorghum of several shades with light grey stones", product_jitter=0.02,
             exposure=0.9),
    _palette("fennel_seeds_stems", [(150, 160, 104), (138, 148, 96)], [(186, 170, 120)],
             "green-grey fennel seeds with pale yellow stems", product_jitter=0.015, ambient=0.45,
             diffuse=0.6),
    _palette("pe_flakes_wood", [(60, 120, 176), (70, 132, 186)], [(150, 110, 70), (220, 220, 214)],
             "blue PE flakes with wood chips and white PE pieces", product_jitter=0.02,
             light_direction=(-0.3, -0.2, 1.0)),
    # the fourteenth held-out set (thirty-first session), named before any of it was rendered
    _palette("rye_ergot", [(150, 128, 98), (138, 118, 90), (160, 138, 106)], [(58, 40, 48)],
             "grey-brown rye of several shades with dark purple ergot bodies", product_jitter=0.02,
             light_direction=(0.2, -0.3, 1.0)),
    _palette("linseed_stones", [(104, 62, 38), (92, 54, 34)], [(138, 130, 120), (70, 66, 62)],
             "glossy brown linseed with grey and dark stones", product_jitter=0.015, ambient=0.5,
             diffuse=0.55),
    _palette("coriander_seeds_stones", [(178, 152, 106), (166, 140, 98)], [(128, 124, 116)],
             "light brown coriander seeds with grey stones", product_jitter=0.02, exposure=1.1),
    _palette("pet_flakes_labels", [(176, 204, 216), (166, 196, 210)], [(236, 236, 230), (196, 56, 52)],
             "light blue PET flakes with white and red label pieces", product_jitter=0.02,
             light_direction=(-0.2, -0.3, 1.0)),
    # the fifteenth held-out set (thirty-seventh session), named before any of it was rendered
    _palette("durum_wheat_stones", [(200, 162, 98), (188, 150, 90), (210, 174, 108)], [(122, 112, 102)],
             "amber durum wheat of several shades with grey-brown stones", product_jitter=0.02,
             light_direction=(0.3, -0.2, 1.0)),
    _palette("green_lentils_stones", [(124, 120, 72), (112, 110, 66)], [(76, 72, 66), (152, 132, 102)],
             "olive-green lentils with dark stones and light clay lumps", product_jitter=0.015, ambient=0.5,
             diffuse=0.55),
    _palette("brazil_nuts_shells", [(214, 198, 162), (202, 184, 148)], [(112, 78, 48)],
             "cream brazil nut kernels with brown shell pieces", product_jitter=0.02, exposure=0.95),
    _palette("pla_flakes_pet", [(226, 222, 210), (216, 212, 200)], [(184, 206, 218), (70, 70, 74)],
             "off-white PLA flakes with light blue PET and dark grey PP pieces", product_jitter=0.02,
             light_direction=(-0.3, 0.2, 1.0)),
)}


def _lab_to_rgb(lab) -> tuple | None:
    rgb = cv2.cvtColor(np.array([[lab]], dtype=np.float32), cv2.COLOR_Lab2RGB)[0, 0]
    back = cv2.cvtColor(np.clip(rgb, 0, 1).reshape(1, 1, 3).astype(np.float32), cv2.COLOR_RGB2Lab)[0, 0]
    if np.any(rgb < -1e-3) or np.any(rgb > 1 + 1e-3) or np.linalg.norm(back - np.asarray(lab)) > 1.0:
        return None  # outside the sRGB gamut
    return tuple(float(v) for v in np.clip(rgb, 0.0, 1.0))


def random_palette(seed: int) -> Palette:
    """A seeded random appearance: a product base colour anywhere in sRGB with 1-3 shades within
    RANDOM_SHADE_DELTA_E, 1-2 impurity colours at RANDOM_IMPURITY_DELTA_E from the product (some close),
    a random light direction, ambient, diffuse and an exposure between 0.7 and 1.4."""
    rng = np.random.default_rng([int(seed), 17])
    while True:
        base_lab = np.array([rng.uniform(12.0, 92.0), rng.uniform(-45.0, 45.0), rng.uniform(-45.0, 55.0)])
        base = _lab_to_rgb(base_lab)
        if base is not None:
            break
    shades = [base]
    for _ in range(int(rng.integers(0, 3))):
        for _attempt in range(50):
            offset = rng.normal(size=3)
            step = offset / np.linalg.norm(offset) * rng.uniform(1.0, RANDOM_SHADE_DELTA_E)
            shade = _lab_to_rgb(base_lab + step)
            if shade is not None:
                shades.append(shade)
                break
    impurities = []
    for _ in range(int(rng.integers(1, 3))):
        for _attempt in range(200):
            direction = rng.normal(size=3)
            distance = rng.uniform(*RANDOM_IMPURITY_DELTA_E)
            colour = _lab_to_rgb(base_lab + direction / np.linalg.norm(direction) * distance)
            if colour is not None and min(delta_e(colour, s) for s in shades) >= RANDOM_IMPURITY_DELTA_E[0]:
                impurities.append(colour)
                break
    if not impurities:  # a base at the gamut's edge: take the farthest grey
        impurities.append((0.5, 0.5, 0.5) if base_lab[0] < 40 or base_lab[0] > 70 else (0.9, 0.9, 0.9))
    azimuth, elevation = rng.uniform(0, 2 * math.pi), rng.uniform(math.radians(45), math.radians(85))
    light = (math.cos(azimuth) * math.cos(elevation), math.sin(azimuth) * math.cos(elevation),
             math.sin(elevation))
    return Palette(name=f"{RANDOM_PREFIX}{int(seed)}", product_shades=tuple(shades),
                   impurity_colors=tuple(impurities), product_jitter=float(rng.uniform(0.005, 0.03)),
                   impurity_jitter=float(rng.uniform(0.0, 0.02)),
                   light_direction=light, ambient=float(rng.uniform(0.45, 0.75)),
                   diffuse=float(rng.uniform(0.3, 0.6)), exposure=float(rng.uniform(0.7, 1.4)),
                   description=f"random palette {int(seed)}")


def known_palette_names() -> list:
    return sorted(PALETTES) + [f"{RANDOM_PREFIX}<seed>"]


# name suffixes, the outermost first: (pattern, the Palette method that applies its value)
_SUFFIXES = ((re.compile(r"^(?P<name>.+)@x(?P<value>[0-9.]+)$"), Palette.with_exposure),
             (re.compile(r"^(?P<name>.+)@j(?P<value>[0-9.]+)$"), Palette.with_product_jitter))


def palette_named(name: str) -> Palette:
    """A palette by name: "" (the default), a named palette, `random-<seed>`, and any of them with an
    exposure suffix `@x<factor>` (e.g. `blocks@x0.5`) or a product jitter suffix `@j<jitter>` (e.g.
    `random-800@j0.05`, Palette.with_product_jitter), both in that order (`random-800@j0.05@x0.5`). ValueError
    lists the known names otherwise, or names the field out of range."""
    name = (name or DEFAULT_PALETTE).strip()
    for pattern, apply in _SUFFIXES:
        suffix = pattern.match(name)
        if suffix:
            try:
                value = float(suffix.group("value"))
            except ValueError:  # e.g. "1.2.3": Palette's range check names the field
                value = float("nan")
            return apply(palette_named(suffix.group("name")), value)
    if name in PALETTES:
        return PALETTES[name]
    if name.startswith(RANDOM_PREFIX) and name[len(RANDOM_PREFIX):].isdigit():
        return random_palette(int(name[len(RANDOM_PREFIX):]))
    raise ValueError(f"unknown palette {name!r}; known: {', '.join(known_palette_names())} "
                     f"(any of them with @j<product jitter> and @x<exposure>, e.g. random-800@j0.05@x0.5)")
