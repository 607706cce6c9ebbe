"""Our VOCUS2 (Frintrop, Werner, Martin Garcia, CVPR 2015): bottom-up saliency from centre-surround
contrast in an opponent colour space.

Steps, as in the paper:
1. Opponent colour space: intensity I = (R + G + B) / 3, red-green RG = R - G,
   blue-yellow BY = B - (R + G) / 2 (values in [0, 1] / [-1, 1]).
2. Twin pyramids per channel: a centre pyramid built like a SIFT scale space (octaves halve the image,
   `n_scales` scales per octave, centre blur sigma_c * 2^(s / n_scales)), and for every centre layer a
   surround layer blurred further so that its total blur is sigma_s (the "new" twin structure: the
   surround is the centre blurred by sqrt(sigma_s^2 - sigma_c^2)).
3. Contrasts per layer: on-off = max(centre - surround, 0) (bright / red / blue on a darker / greener
   / yellower surround) and off-on = max(surround - centre, 0).
4. Mean fusion: the layers of each contrast (resized to the finest layer) -> 6 feature maps; on-off and
   off-on of a channel -> 3 conspicuity maps (I, RG, BY); their mean -> the saliency map.

Unlike the original, the returned saliency is NOT normalised to [0, 1]: its values are contrasts in
opponent-colour units, so one threshold ("is the best region contrasted enough to be an impurity?")
means the same thing in every scene. `normalised()` gives the [0, 1] picture for display.

Parameters (SaliencyParams): the original defaults are sigma_c = 3, sigma_s = 13, 2 scales per octave,
layers 0..4; its authors recommend sigma_c = 2, sigma_s = 6 for cluttered robot scenes with many small
objects. Our cell default is chosen on rendered scenes of the tuning palettes (see CELL_SALIENCY below
for the values and why).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from impurity_common.parameters import InvalidParameter, check_fields, param

CHANNELS = ("I", "RG", "BY")
MIN_CHANNEL_LEVEL = 1e-4  # a conspicuity map flatter than this over the objects is noise (a level's floor)
HALF_RES_SIGMA = 5.0  # px; surround blurs at least this wide are computed at half resolution


@dataclass(frozen=True)
class SaliencyParams:
    """VOCUS2's pyramid (ROS parameters saliency.*)."""

    center_sigma: float = param(3.0, "VOCUS2 centre blur of the finest layer (px)", low=0.1, high=50.0)
    surround_sigma: float = param(13.0, "VOCUS2 surround blur (px, > centre)", low=0.1, high=100.0)
    n_scales: int = param(2, "VOCUS2 scales per octave", low=1, high=8)
    start_layer: int = param(0, "VOCUS2 first pyramid octave (0 = full resolution)", low=0, high=6)
    stop_layer: int = param(4, "VOCUS2 last pyramid octave (each halves the image)", low=0, high=6)

    def __post_init__(self):
        check_fields(self)
        if self.surround_sigma <= self.center_sigma:
            raise InvalidParameter("surround_sigma", f"is not above center_sigma ({self.center_sigma})")
        if self.stop_layer < self.start_layer:
            raise InvalidParameter("stop_layer", f"is below start_layer ({self.start_layer})")


VOCUS2_DEFAULTS = SaliencyParams()  # the CVPR 2015 defaults (MSRA-style images, large objects)
VOCUS2_CLUTTER = SaliencyParams(center_sigma=2.0, surround_sigma=6.0)  # the authors' "cluttered scenes"
# Cell default, on the 224 x 224 colour heightmap (2 mm/px; blocks are 13-50 px across): the CVPR 2015
# defaults. On rendered scenes of the tuning palettes, impurities found at 2.2 % false TARGET:
# (3, 13) 97.7 %, (2, 10, 3 octaves) 96.8 %, (2, 6) 95.5 %.
CELL_SALIENCY = VOCUS2_DEFAULTS


@dataclass
class SaliencyMaps:
    saliency: np.ndarray  # (H, W) float32, mean contrast (opponent-colour units), input size
    conspicuity: dict = field(default_factory=dict)  # channel -> (H, W) float32
    features: dict = field(default_factory=dict)  # "I_on_off", "I_off_on", ... -> finest-layer size


def opponent_colour(rgb: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB -> (H, W, 3) float32 planes I, RG, BY (the CoDi opponent space)."""
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) RGB image, got shape {rgb.shape}")
    scaled = rgb.astype(np.float32) * np.float32(1.0 / 255.0)
    r, g, b = scaled[..., 0], scaled[..., 1], scaled[..., 2]
    return np.stack([(r + g + b) / 3.0, r - g, b - (r + g) / 2.0], axis=-1)


CHROMA_MIN_INTENSITY = 0.05  # I below this divides by this: chromaticity of near-black cells is noise
COLOUR_SPACES = ("opponent", "chromaticity")


def opponent_chromaticity(rgb: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB -> (H, W, 3) float32 planes I, RG / I, BY / I. The chromatic planes are
    unchanged when a surface is lit more or less (shading and exposure scale R, G and B alike), so
    their contrasts are differences of colour, not of light; I keeps the lightness contrast."""
    planes = opponent_colour(rgb)
    intensity = np.maximum(planes[..., :1], CHROMA_MIN_INTENSITY)
    return np.concatenate([planes[..., :1], planes[..., 1:] / intensity], axis=-1)


def _blur(image: np.ndarray, sigma: float) -> np.ndarray:
    return cv2.GaussianBlur(image, (0, 0), sigmaX=sigma, sigmaY=sigma, borderType=cv2.BORDER_REPLICATE)


def surround(centre: np.ndarray, sigma: float) -> np.ndarray:
    """Surround layer: `centre` blurred by `sigma` px. Wide blurs (sigma >= HALF_RES_SIGMA) run at
    half resolution and are upsampled: the error is far below the contrasts that matter (the
    area-downsampling adds a blur of variance 1/3 px^2 to sigma^2 >= 25; measured: <= 3.5 % of the peak
    saliency) and it saves ~3/4 of the blur time."""
    height, width = centre.shape[:2]
    if sigma < HALF_RES_SIGMA or min(height, width) < 16:
        return _blur(centre, sigma)
    small = cv2.resize(centre, (width // 2, height // 2), interpolation=cv2.INTER_AREA)
    return cv2.resize(_blur(small, sigma / 2.0), (width, height), interpolation=cv2.INTER_LINEAR)


def centre_pyramid(planes: np.ndarray, params: SaliencyParams) -> list:
    """Scale space of `planes` (H, W, C): a list over octaves of lists over scales, each layer blurred
    to sigma_c * 2^(s / n_scales) relative to its octave's resolution (Lowe 2004)."""
    sigma, n = params.center_sigma, params.n_scales
    image = planes
    for _ in range(params.start_layer):  # octaves below start_layer only feed the next one
        image = _blur(image, 2.0 * sigma)[::2, ::2]
    max_octave = min(int(math.log2(max(2, min(planes.shape[:2])))), params.stop_layer)
    pyramid = []
    for _octave in range(max_octave - params.start_layer + 1):
        if min(image.shape[:2]) < 2:
            break
        layers, previous_sigma = [], 0.0
        current = image
        for s in range(n + 1):  # the extra scale seeds the next octave
            total = sigma * 2.0 ** (s / n)
            step = math.sqrt(max(total * total - previous_sigma * previous_sigma, 1e-6))
            current = _blur(current, step)
            layers.append(current)
            previous_sigma = total
        pyramid.append(layers[:n])
        image = np.ascontiguousarray(layers[n][::2, ::2])
    return pyramid


def vocus2(rgb: np.ndarray, params: SaliencyParams = CELL_SALIENCY, keep_features: bool = False,
           colour_space: str = "opponent") -> SaliencyMaps:
    """Saliency map of an RGB image (H, W, 3) uint8 -> SaliencyMaps (saliency at input size).
    colour_space "opponent": VOCUS2's I, RG, BY; "chromaticity": I, RG / I, BY / I
    (opponent_chromaticity; the chromatic maps are then in units of I, not of RGB)."""
    if colour_space not in COLOUR_SPACES:
        raise ValueError(f"colour_space {colour_space!r} not one of {COLOUR_SPACES}")
    planes = opponent_colour(rgb) if colour_space == "opponent" else opponent_chromaticity(rgb)
    pyramid = centre_pyramid(planes, params)
    if not pyramid:
        raise ValueError(f"image {rgb.shape[:2]} too small for a saliency pyramid")
    extra_sigma = math.sqrt(params.surround_sigma ** 2 - params.center_sigma ** 2)
    # Mean fusion over all layers, accumulated from the coarsest octave up: resizing is linear, so
    # upsampling the running sums once per octave equals resizing every layer to the finest size.
    # off-on = max(-d, 0) = max(d, 0) - d, which keeps every operation on contiguous arrays.
    on_running = off_running = None
    count = 0
    for octave in reversed(pyramid):
        layer_h, layer_w = octave[0].shape[:2]
        on_level = np.zeros((layer_h, layer_w, 3), dtype=np.float32)
        off_level = np.zeros((layer_h, layer_w, 3), dtype=np.float32)
        for s, centre in enumerate(octave):
            difference = centre - surround(centre, extra_sigma * 2.0 ** (s / params.n_scales))
            positive = np.maximum(difference, 0.0)
            on_level += positive
            off_level += positive
            off_level -= difference
            count += 1
        if on_running is not None:
            on_level += cv2.resize(on_running, (layer_w, layer_h), interpolation=cv2.INTER_CUBIC)
            off_level += cv2.resize(off_running, (layer_w, layer_h), interpolation=cv2.INTER_CUBIC)
        on_running, off_running = on_level, off_level
    base_h, base_w = on_running.shape[:2]
    on_off_sum, off_on_sum = on_running, off_running
    # cubic upsampling overshoots a little below zero; contrasts are non-negative by definition
    on_off_feature = np.maximum(on_off_sum / count, 0.0)
    off_on_feature = np.maximum(off_on_sum / count, 0.0)
    conspicuity_stack = (on_off_feature + off_on_feature) / 2.0
    saliency = conspicuity_stack.mean(axis=2)
    height, width = rgb.shape[:2]
    if (base_h, base_w) != (height, width):
        saliency = np.maximum(cv2.resize(saliency, (width, height), interpolation=cv2.INTER_CUBIC), 0.0)
    maps = SaliencyMaps(saliency=saliency.astype(np.float32))
    if keep_features:
        for c, name in enumerate(CHANNELS):
            maps.conspicuity[name] = conspicuity_stack[..., c]
            maps.features[f"{name}_on_off"] = on_off_feature[..., c]
            maps.features[f"{name}_off_on"] = off_on_feature[..., c]
    return maps


def normalised(saliency: np.ndarray) -> np.ndarray:
    """[0, 1] version for display (what VOCUS2 itself outputs); a flat map gives zeros."""
    low, high = float(np.min(saliency)), float(np.max(saliency))
    if not math.isfinite(high - low) or high - low < 1e-12:
        return np.zeros_like(saliency, dtype=np.float32)
    return ((saliency - low) / (high - low)).astype(np.float32)
