"""Thirty-third session, tuning data only, a second screening (nothing is adopted on it): does finer colour
evidence than off_colour_share's 16-bin RGB histogram find more near-product impurities?

To the shipped fifteen features (A) it adds, one group at a time, the share of a region's cells whose colour
lies off the product's colours, the product being the verifier's P (object cells outside the region grown by
PRODUCT_MARGIN) and "off" impurity_common.colour.off_colours' test (a cell's smoothed histogram density below
that of the product's own 1 % least likely cells), read
- D: in RGB, 32 bins per channel, 26 neighbours;
- E: in chromaticity (R / (R + G + B), G / (R + G + B); shading leaves it), 64 bins per axis, 8 neighbours,
  cells of R + G + B >= 30 only;
- F: in CIE L*a*b* (OpenCV's float scale), bins of 4 units, 26 neighbours;
- G: all three.
Compared as docs/experiments_s33/excluded_screen.py compares (palette-grouped 5-fold cross-validation on the
260 fresh tuning palettes, thresholds from the training folds at 1 % false TARGET; then fitted on all and read
on the default palette's exposure set, tuning seeds 30000+).

    python docs/experiments_s33/fine_colour_screen.py [--jobs 2]
Rows are cached in runs/s33/fine_rows.npz.
"""
import argparse
import pathlib
import sys

import cv2
import numpy as np

sys.path[:0] = ["scripts", "docs/experiments_s11", "docs/experiments_s12", "docs/experiments_s13",
                "docs/experiments_s33"]
import excluded_screen as ex  # noqa: E402

from impurity_attention.core.verifier import FEATURES, PRODUCT_MARGIN  # noqa: E402

CACHE = pathlib.Path("runs/s33/fine_rows.npz")
FINE = ("off_rgb32", "off_chroma", "off_lab")
ALL = FEATURES + FINE
MODELS = {"A shipped fifteen": FEATURES, "D + off_rgb32": FEATURES + FINE[:1],
          "E + off_chroma": FEATURES + FINE[1:2], "F + off_lab": FEATURES + FINE[2:],
          "G + all three": FEATURES + FINE}
QUANTILE = 0.01


def off_share(codes_product: np.ndarray, codes_region: np.ndarray, bins: int) -> float:
    """The share of region cells whose smoothed density (over the neighbouring bins) among the product's
    cells is below the density at the product's own QUANTILE least likely cells. codes: (N, k) ints in
    [0, bins), k 2 or 3."""
    k = codes_product.shape[1]
    side = bins + 2
    flat = np.ravel_multi_index(tuple((codes_product + 1).T), (side,) * k)
    counts = np.bincount(flat, minlength=side ** k).astype(np.float64).reshape((side,) * k)
    offsets = np.stack(np.meshgrid(*([(-1, 0, 1)] * k), indexing="ij"), -1).reshape(-1, k)
    smooth = np.zeros((bins,) * k)
    for offset in offsets:
        smooth += counts[tuple(slice(1 + o, bins + 1 + o) for o in offset)]
    level = np.quantile(smooth[tuple(codes_product.T)], QUANTILE)
    return float(np.mean(smooth[tuple(codes_region.T)] < level))


def fine_features(color: np.ndarray, region: np.ndarray, product: np.ndarray) -> list:
    rgb = color.astype(np.int64)
    values = [off_share((rgb[product] * 32) // 256, (rgb[region] * 32) // 256, 32)]
    total = rgb.sum(axis=-1)
    bright = total >= 30
    p, m = product & bright, region & bright
    if p.sum() > 10 and m.any():
        chroma = rgb[..., :2] / np.maximum(total, 1)[..., None]
        codes = np.clip((chroma * 64).astype(np.int64), 0, 63)
        values.append(off_share(codes[p], codes[m], 64))
    else:
        values.append(np.nan)
    lab = cv2.cvtColor(color.astype(np.float32) / 255.0, cv2.COLOR_RGB2Lab)
    shift = np.array([0.0, 128.0, 128.0])
    codes = np.clip(((lab + shift) / 4.0).astype(np.int64), 0, 63)
    values.append(off_share(codes[product], codes[region], 64))
    return values


def rows_of(index: int) -> list:
    """[(features (len(ALL),), on target)] of excluded_screen.RECORDS[index]'s scored regions."""
    view = ex.scored_view(ex.RECORDS[index])
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * PRODUCT_MARGIN + 1,) * 2)
    out = []
    for _, region, row, on in view.candidates:
        product = view.objects & ~(cv2.dilate(region.mask.astype(np.uint8), kernel) > 0)
        if not product.any():
            product = view.objects & ~region.mask
        out.append((np.concatenate([row, fine_features(view.color, region.mask, product)]), on))
    return out


def main() -> None:
    """excluded_screen's comparison with this screening's rows, models and cache."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--jobs", type=int, default=2)
    ex.run(CACHE, rows_of, ALL, MODELS, parser.parse_args().jobs)


if __name__ == "__main__":
    main()
