"""Optional sim-to-real colour adaptation (paper section 6.4, Fig. 12): Reinhard et al. 2001 colour
transfer in CIE Lab. Each Lab channel of an incoming image is shifted and scaled so that its mean and
standard deviation match reference statistics measured on simulator images; the attention thresholds
calibrated in simulation then keep their meaning on a real camera. Off by default.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

MIN_STD = 1e-3  # Lab units; a channel flatter than this is shifted but not scaled


@dataclass(frozen=True)
class LabStatistics:
    mean: tuple  # (L, a, b), OpenCV float Lab: L in [0, 100], a and b about [-127, 127]
    std: tuple

    def __post_init__(self):
        if len(self.mean) != 3 or len(self.std) != 3 or min(self.std) < 0:
            raise ValueError(f"Lab statistics need 3 means and 3 non-negative stds, got {self}")


def _to_lab(rgb: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(rgb.astype(np.float32) * np.float32(1.0 / 255.0), cv2.COLOR_RGB2Lab)


def lab_statistics(images, valid_masks=None) -> LabStatistics:
    """Mean and std of the Lab channels over the (valid pixels of the) given RGB images."""
    samples = []
    for i, rgb in enumerate(images):
        lab = _to_lab(rgb).reshape(-1, 3)
        if valid_masks is not None and valid_masks[i] is not None:
            lab = lab[np.asarray(valid_masks[i]).reshape(-1)]
        samples.append(lab)
    pixels = np.concatenate(samples) if samples else np.zeros((0, 3), np.float32)
    if len(pixels) == 0:
        raise ValueError("no pixels to measure Lab statistics on")
    return LabStatistics(tuple(float(v) for v in pixels.mean(axis=0)),
                         tuple(float(v) for v in pixels.std(axis=0)))


def reinhard_transfer(rgb: np.ndarray, reference: LabStatistics, valid: np.ndarray | None = None
                      ) -> np.ndarray:
    """RGB (H, W, 3) uint8 -> RGB uint8 with `reference` Lab statistics. Pixels outside `valid`
    (e.g. unseen black heightmap cells) are neither measured nor changed."""
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"expected (H, W, 3) uint8 RGB, got {rgb.shape} {rgb.dtype}")
    lab = _to_lab(rgb)
    use = np.ones(rgb.shape[:2], bool) if valid is None else np.asarray(valid, bool)
    if not use.any():
        return rgb.copy()
    source = lab[use]
    mean, std = source.mean(axis=0), source.std(axis=0)
    scale = np.where(std > MIN_STD, np.asarray(reference.std) / np.maximum(std, MIN_STD), 1.0)
    adapted = (lab - mean) * scale.astype(np.float32) + np.asarray(reference.mean, np.float32)
    adapted[..., 0] = np.clip(adapted[..., 0], 0.0, 100.0)
    out = cv2.cvtColor(adapted.astype(np.float32), cv2.COLOR_Lab2RGB)
    out = np.clip(np.round(out * 255.0), 0, 255).astype(np.uint8)
    result = rgb.copy()
    result[use] = out[use]
    return result
