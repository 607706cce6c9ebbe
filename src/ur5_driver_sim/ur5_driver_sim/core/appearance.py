"""What a simulated scene looks like: product and impurity colours, light and camera exposure.

The cell's promise (paper sections 1 and 5.1.1) is that nobody tells it what the impurities look like,
so the simulator renders the same layouts under many appearances:

- `Palette`: the product's colour distribution (one or several base shades, a per-block jitter), the
  impurity colours (one or several per scene; they may be close to the product), the light (direction,
  ambient and diffuse strength of PyBullet's TinyRenderer) and the camera's exposure (a factor on the
  rendered RGB, clipped to 255 like a saturating sensor).
- `PALETTES`: named palettes modelled on real sorting jobs, read from data/palettes.yaml (`load_palettes`
  checks it; `PALETTE_SPLITS` gives each one's split), plus `random_palette(seed)` generated in code,
  addressed by name as `random-<seed>`, and `lightness_palette(seed)`, impurities differing from the
  product mainly in lightness, addressed as `lightness-<seed>`. `palette_named(name)` refuses an unknown
  name with the list of known ones.
- `BlockColours`: the per-scene colour draw. Product blocks take their jitter from the layout's random
  generator (three uniforms in +- LAYOUT_JITTER per block, scaled to the palette's product_jitter); the
  choice of shade and impurity colour comes from a second generator seeded by the scene seed, so one seed
  gives the same layout under every palette.

Colours are RGB in [0, 1] (PyBullet's rgbaColor); `delta_e` is the CIE76 distance in CIE Lab (OpenCV's
float Lab, L in [0, 100]), the usual measure of "how different do two colours look".
"""

from __future__ import annotations

import math
import pathlib
import re
from dataclasses import dataclass, replace

import cv2
import numpy as np
import yaml

from . import config

LAYOUT_JITTER = config.PRODUCT_SHADE_JITTER  # the layout rng draws uniform(-this, this) per channel
RANDOM_PREFIX = "random-"
DEFAULT_PALETTE = "blocks"
DEFAULT_LIGHT_DIRECTION = (0.3, 0.2, 1.0)
DEFAULT_AMBIENT = 0.6
DEFAULT_DIFFUSE = 0.45
# random palettes: how far (CIE76 Delta E) an impurity lies from the product's mean shade. 12 is about
# what a sorting operator calls "clearly different" on a matte surface; 60 is red among blue.
RANDOM_IMPURITY_DELTA_E = (12.0, 60.0)
RANDOM_SHADE_DELTA_E = 4.0  # at most this between a random palette's product shades
# lightness palettes (lightness_palette): impurities that differ from the product mainly in lightness (stones
# among grain, ash among ore, grey plastic among white), at this Delta E from the product's base shade ...
LIGHTNESS_PREFIX = "lightness-"
LIGHTNESS_DELTA_E = (12.0, 20.0)
LIGHTNESS_MAX_CHROMA_SHIFT = 4.0  # ... with at most this change in (a*, b*): nearly the product's hue, chroma
LIGHTNESS_EXPOSURE = (0.7, 1.4)  # the exposure of most lightness palettes, as random palettes'
LIGHTNESS_BRIGHT_EXPOSURE = (1.4, 1.8)  # a bright exposure, in LIGHTNESS_BRIGHT_SHARE of them
LIGHTNESS_BRIGHT_SHARE = 0.25
# every lightness palette's colours keep their brightest channel x (ambient + diffuse) x exposure at most
# this: a face lit head-on stays below the camera's ceiling, so the lightness difference is in the image (a
# lighter impurity on a light product clipped to white with it would be no case for any detector)
LIGHTNESS_CEILING = 0.95
COLOUR_SEED_SALT = 0x5EED_C010  # the colour generator's seed: scene seed XOR this


def _rgb(values) -> tuple:
    return tuple(float(v) / 255.0 for v in values)


def delta_e(a, b) -> float:
    """CIE76 colour difference of two RGB colours in [0, 1] (Lab via OpenCV, D65)."""
    pixels = np.array([[a, b]], dtype=np.float32)
    lab = cv2.cvtColor(pixels, cv2.COLOR_RGB2Lab)[0]
    return float(np.linalg.norm(lab[0] - lab[1]))


def chroma_shift(a, b) -> float:
    """The (a*, b*) part of delta_e: how much two RGB colours in [0, 1] differ in hue and chroma, not
    lightness."""
    lab = cv2.cvtColor(np.array([[a, b]], dtype=np.float32), cv2.COLOR_RGB2Lab)[0]
    return float(np.linalg.norm(lab[0, 1:] - lab[1, 1:]))


@dataclass(frozen=True)
class Palette:
    """One appearance. Raises ValueError naming the bad field when a value is out of range."""

    name: str
    product_shades: tuple  # ((r, g, b), ...) in [0, 1]: each product block takes one of these
    impurity_colors: tuple  # ((r, g, b), ...) in [0, 1]: each impurity takes one of these
    product_jitter: float = LAYOUT_JITTER  # +- per channel and block
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
        """A product block's colour; draws 3 uniforms in +- LAYOUT_JITTER from `layout_rng`."""
        noise = [layout_rng.uniform(-LAYOUT_JITTER, LAYOUT_JITTER) for _ in range(3)]
        shades = self.palette.product_shades
        base = shades[self.rng.integers(len(shades))] if len(shades) > 1 else shades[0]
        scale = self.palette.product_jitter / LAYOUT_JITTER
        return tuple(float(np.clip(c + n * scale, 0.0, 1.0))
                     for c, n in zip(base, noise, strict=True))

    def impurity(self) -> tuple:
        colours = self.palette.impurity_colors
        base = colours[self.rng.integers(len(colours))] if len(colours) > 1 else colours[0]
        jitter = self.palette.impurity_jitter
        if jitter <= 0.0:
            return tuple(base)
        return tuple(float(np.clip(c + self.rng.uniform(-jitter, jitter), 0.0, 1.0)) for c in base)


PALETTES_FILE = pathlib.Path(__file__).resolve().parents[1] / "data" / "palettes.yaml"
SPLITS = ("default", "tuning", "held_out", "spare")  # the values of a palette's `split` (palettes.yaml)
_ENTRY_FIELDS = ("name", "split", "description", "product_shades", "impurity_colours", "product_jitter",
                 "impurity_jitter", "light", "exposure")
_LIGHT_FIELDS = ("direction", "ambient", "diffuse")


class PaletteFileError(ValueError):
    """A palettes file that cannot be read; the message names the file, the palette and the field."""


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _palette_from_entry(entry: dict, where: str) -> tuple[Palette, str]:
    """(Palette, split) of one palettes.yaml entry; PaletteFileError prefixed with `where` names the field."""
    missing = [f for f in _ENTRY_FIELDS if f not in entry]
    unknown = sorted(set(entry) - set(_ENTRY_FIELDS))
    if missing or unknown:
        raise PaletteFileError(f"{where}: " + "; ".join(
            ([f"missing {', '.join(missing)}"] if missing else []) +
            ([f"unknown field {', '.join(unknown)} (known: {', '.join(_ENTRY_FIELDS)})"] if unknown else [])))
    if entry["split"] not in SPLITS:
        raise PaletteFileError(f"{where}: split: expected one of {', '.join(SPLITS)}, got {entry['split']!r}")
    if not isinstance(entry["description"], str):
        raise PaletteFileError(f"{where}: description: expected text, got {entry['description']!r}")
    colours = {}
    for field in ("product_shades", "impurity_colours"):
        values = entry[field]
        if not isinstance(values, list) or not values:
            raise PaletteFileError(f"{where}: {field}: expected a list of at least one [r, g, b], "
                                   f"got {values!r}")
        for k, colour in enumerate(values):
            if not (isinstance(colour, list) and len(colour) == 3 and
                    all(_is_number(c) and 0 <= c <= 255 for c in colour)):
                raise PaletteFileError(f"{where}: {field}[{k}]: expected 3 numbers in 0..255, got {colour!r}")
        colours[field] = tuple(_rgb(c) for c in values)
    light = entry["light"]
    if not isinstance(light, dict) or sorted(light) != sorted(_LIGHT_FIELDS):
        raise PaletteFileError(f"{where}: light: expected {{direction: [x, y, z], ambient: a, diffuse: d}}, "
                               f"got {light!r}")
    direction = light["direction"]
    if not (isinstance(direction, list) and len(direction) == 3 and all(_is_number(v) for v in direction)):
        raise PaletteFileError(f"{where}: light.direction: expected 3 numbers, got {direction!r}")
    numbers = {"product_jitter": entry["product_jitter"], "impurity_jitter": entry["impurity_jitter"],
               "light.ambient": light["ambient"], "light.diffuse": light["diffuse"],
               "exposure": entry["exposure"]}
    for field, value in numbers.items():
        if not _is_number(value):
            raise PaletteFileError(f"{where}: {field}: expected a number, got {value!r}")
    try:
        palette = Palette(name=entry["name"], product_shades=colours["product_shades"],
                          impurity_colors=colours["impurity_colours"],
                          product_jitter=float(entry["product_jitter"]),
                          impurity_jitter=float(entry["impurity_jitter"]),
                          light_direction=tuple(float(v) for v in direction), ambient=float(light["ambient"]),
                          diffuse=float(light["diffuse"]), exposure=float(entry["exposure"]),
                          description=entry["description"])
    except ValueError as error:  # a range check of Palette: it names the field
        raise PaletteFileError(f"{where}: {error}") from error
    return palette, entry["split"]


def load_palettes(path: pathlib.Path | str = PALETTES_FILE) -> tuple[dict, dict]:
    """The named palettes of a palettes file (format: data/palettes.yaml's header): ({name: Palette} in the
    file's order, {name: split}). Raises PaletteFileError naming the file, the palette and the bad field
    (e.g. "palettes.yaml: palette 'coal_slate': impurity_colours[1]: expected 3 numbers in 0..255, got
    [12, 300, 4]"); a file needs exactly one palette of split "default", named DEFAULT_PALETTE."""
    path = pathlib.Path(path)
    try:
        document = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise PaletteFileError(f"{path.name}: not YAML: {error}") from error
    entries = document.get("palettes") if isinstance(document, dict) else None
    if not isinstance(entries, list) or not entries:
        raise PaletteFileError(f"{path.name}: expected a mapping with a non-empty list `palettes`")
    palettes, split_of = {}, {}
    for index, entry in enumerate(entries):
        if not isinstance(entry, dict):
            raise PaletteFileError(f"{path.name}: palettes[{index}]: expected a mapping, got {entry!r}")
        name = entry.get("name")
        if not isinstance(name, str) or not re.fullmatch(r"[a-z][a-z0-9_]*", name) or \
                name.startswith(RANDOM_PREFIX.rstrip("-")):
            raise PaletteFileError(f"{path.name}: palettes[{index}]: name: expected lower_snake_case not "
                                   f"starting with 'random', got {name!r}")
        if name in palettes:
            raise PaletteFileError(f"{path.name}: palette {name!r}: name: listed twice")
        palettes[name], split_of[name] = _palette_from_entry(entry, f"{path.name}: palette {name!r}")
    defaults = [name for name, split in split_of.items() if split == "default"]
    if defaults != [DEFAULT_PALETTE]:
        raise PaletteFileError(f"{path.name}: split: exactly one palette, {DEFAULT_PALETTE!r}, has split "
                               f"'default'; got {defaults}")
    return palettes, split_of


# The named palettes, modelled on real sorting jobs, and the split each belongs to (data/palettes.yaml).
PALETTES, PALETTE_SPLITS = load_palettes()


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


def lightness_palette(seed: int) -> Palette:
    """A seeded appearance whose impurities differ from the product mainly in lightness: a product base
    colour anywhere in sRGB (L* 15 ... 85) with 1-3 shades within RANDOM_SHADE_DELTA_E, 1-2 impurity colours
    at LIGHTNESS_DELTA_E from the base (and at least its low end from every shade), darker or lighter, whose
    (a*, b*) differ from the base's by at most LIGHTNESS_MAX_CHROMA_SHIFT; a random light as random_palette's;
    exposure in LIGHTNESS_EXPOSURE, or in LIGHTNESS_BRIGHT_EXPOSURE for LIGHTNESS_BRIGHT_SHARE of the seeds;
    colours drawn below LIGHTNESS_CEILING (unclipped where lit head-on; a bright palette's product is the
    darker for it)."""
    rng = np.random.default_rng([int(seed), 23])
    azimuth, elevation = rng.uniform(0, 2 * math.pi), rng.uniform(math.radians(45), math.radians(85))
    light = (math.cos(azimuth) * math.cos(elevation), math.sin(azimuth) * math.cos(elevation),
             math.sin(elevation))
    ambient, diffuse = float(rng.uniform(0.45, 0.75)), float(rng.uniform(0.3, 0.6))
    bright = rng.uniform() < LIGHTNESS_BRIGHT_SHARE
    exposure = float(rng.uniform(*(LIGHTNESS_BRIGHT_EXPOSURE if bright else LIGHTNESS_EXPOSURE)))
    ceiling = LIGHTNESS_CEILING / ((ambient + diffuse) * exposure)
    while True:
        base_lab = np.array([rng.uniform(15.0, 85.0), rng.uniform(-35.0, 35.0), rng.uniform(-35.0, 45.0)])
        base = _lab_to_rgb(base_lab)
        if base is None or max(base) > ceiling:
            continue
        shades = [base]
        for _ in range(int(rng.integers(0, 3))):
            for _attempt in range(50):
                offset = rng.normal(size=3)
                shade = _lab_to_rgb(base_lab + offset / np.linalg.norm(offset) *
                                    rng.uniform(1.0, RANDOM_SHADE_DELTA_E))
                if shade is not None and max(shade) <= ceiling:
                    shades.append(shade)
                    break
        impurities = []
        for _ in range(int(rng.integers(1, 3))):
            for _attempt in range(200):
                angle, shift = rng.uniform(0, 2 * math.pi), rng.uniform(0.0, LIGHTNESS_MAX_CHROMA_SHIFT - 0.5)
                chroma_step = np.array([math.cos(angle), math.sin(angle)]) * shift
                distance = rng.uniform(*LIGHTNESS_DELTA_E)
                lightness_step = math.sqrt(distance * distance - shift * shift) * rng.choice((-1.0, 1.0))
                colour = _lab_to_rgb(base_lab + np.array([lightness_step, *chroma_step]))
                if colour is not None and max(colour) <= ceiling and \
                        chroma_shift(colour, base) <= LIGHTNESS_MAX_CHROMA_SHIFT and \
                        LIGHTNESS_DELTA_E[0] <= delta_e(colour, base) <= LIGHTNESS_DELTA_E[1] and \
                        min(delta_e(colour, s) for s in shades) >= LIGHTNESS_DELTA_E[0]:
                    impurities.append(colour)
                    break
        if impurities:  # else a base where no lightness step fits the gamut: draw another
            break
    return Palette(name=f"{LIGHTNESS_PREFIX}{int(seed)}", product_shades=tuple(shades),
                   impurity_colors=tuple(impurities), product_jitter=float(rng.uniform(0.005, 0.03)),
                   impurity_jitter=float(rng.uniform(0.0, 0.02)), light_direction=light, ambient=ambient,
                   diffuse=diffuse, exposure=exposure, description=f"lightness palette {int(seed)}")


def known_palette_names() -> list:
    return sorted(PALETTES) + [f"{RANDOM_PREFIX}<seed>", f"{LIGHTNESS_PREFIX}<seed>"]


# name suffixes, the outermost first: (pattern, the Palette method that applies its value)
_SUFFIXES = ((re.compile(r"^(?P<name>.+)@x(?P<value>[0-9.]+)$"), Palette.with_exposure),
             (re.compile(r"^(?P<name>.+)@j(?P<value>[0-9.]+)$"), Palette.with_product_jitter))


def palette_named(name: str) -> Palette:
    """A palette by name: "" (the default), a named palette, `random-<seed>`, `lightness-<seed>`, and any of
    them with an exposure suffix `@x<factor>` (e.g. `blocks@x0.5`) or a product jitter suffix `@j<jitter>`
    (e.g. `random-800@j0.05`, Palette.with_product_jitter), both in that order (`random-800@j0.05@x0.5`).
    ValueError lists the known names otherwise, or names the field out of range."""
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
    if name.startswith(LIGHTNESS_PREFIX) and name[len(LIGHTNESS_PREFIX):].isdigit():
        return lightness_palette(int(name[len(LIGHTNESS_PREFIX):]))
    raise ValueError(f"unknown palette {name!r}; known: {', '.join(known_palette_names())} "
                     f"(any of them with @j<product jitter> and @x<exposure>, e.g. random-800@j0.05@x0.5)")
