"""A small fully convolutional network that marks the cells of a colour heightmap that look like an impurity
among the product around them. The region verifier (verifier.py) reads it as two more features of each
salient region (NETWORK_FEATURES there): where the hand-made features compare one region's colours with the
rest of the view, the network sees whole objects, their faces and their neighbours.

Input (scene_planes): four planes relative to the scene, so that neither the product's colour nor the
exposure sets them. CIE L*a*b* (OpenCV's, of sRGB in [0, 1]) of each cell minus the median over the view's
object cells, divided by that channel's median absolute deviation there (at least MAD_FLOOR Lab units), and
the height in m x HEIGHT_SCALE; cells without an object are 0 in every plane. The planes are averaged over
POOL x POOL cells (4 mm at the cell's 2 mm heightmap) before the network and its output is read back at full
size (bilinear), so a heightmap of any size works (padded with empty cells to a multiple of 8).

Network (ImpurityNet): three resolutions (full, 1/2, 1/4 of the pooled grid; dilations 2, 4, 8 at the
lowest), each 3 x 3 convolution followed by batch normalisation and ReLU, the coarser levels upsampled and
concatenated back (a U-Net-like encoder-decoder), one logit per cell. About 0.16 M weights at width 24; CPU
inference on a 224 x 224 heightmap takes 8-10 ms p50 on 2 threads (`python benchmarks/bench_perception.py
--repeats 20`; `make bench` prints it).

Weights: written by the trainer (impurity_learning.impurity_net_training, on tuning palettes and tuning
seeds only) as a dict {"format_version", "width", "state_dict" (float16), "provenance"}; read_network checks
them and says what is wrong. The shipped file is checkpoints/impurity_net.pt of this package.
"""

from __future__ import annotations

import pathlib

import cv2
import numpy as np
import torch
from torch import nn

from impurity_common.weights_file import check_tensors, read_versioned

from .checkpoints import SOURCE_CHECKPOINTS, shipped_path

MAD_FLOOR = 2.0  # Lab units: the least spread a channel is divided by
HEIGHT_SCALE = 20.0  # height plane = height (m) x this
POOL = 2  # cells averaged per side before the network
MULTIPLE = 4 * POOL  # a heightmap is padded to a multiple of this (the network halves twice)
FORMAT_VERSION = 1
# The shipped weights in the source tree (a ROS install also has them in the package's share dir:
# shipped_network_path).
SHIPPED_NETWORK = SOURCE_CHECKPOINTS / "impurity_net.pt"


class NetworkFileError(RuntimeError):
    """A weights file this code cannot use; the message says which file and why."""


def scene_planes(color: np.ndarray, height: np.ndarray, objects: np.ndarray) -> np.ndarray:
    """(4, H, W) float32: normalised L*, a*, b* and scaled height (module docstring). color (H, W, 3) uint8
    RGB, height (H, W) m, objects (H, W) bool. All zero without object cells."""
    objects = np.asarray(objects, dtype=bool)
    planes = np.zeros((4, *objects.shape), np.float32)
    if not objects.any():
        return planes
    lab = cv2.cvtColor(np.asarray(color, dtype=np.float32) / 255.0, cv2.COLOR_RGB2Lab)
    cells = lab[objects]
    median = np.median(cells, axis=0)
    spread = np.maximum(np.median(np.abs(cells - median), axis=0), MAD_FLOOR)
    planes[:3] = np.moveaxis((lab - median) / spread, -1, 0) * objects
    planes[3] = np.asarray(height, np.float32) * HEIGHT_SCALE * objects
    return planes


def pooled(planes: np.ndarray) -> np.ndarray:
    """(C, H, W) -> (C, ceil(H / MULTIPLE) x MULTIPLE / POOL, ...): padded with zeros (empty cells) to a
    multiple of MULTIPLE, then the mean of each POOL x POOL block."""
    c, h, w = planes.shape
    padded = np.pad(planes, ((0, 0), (0, (-h) % MULTIPLE), (0, (-w) % MULTIPLE)))
    _, h, w = padded.shape
    return padded.reshape(c, h // POOL, POOL, w // POOL, POOL).mean(axis=(2, 4))


class ImpurityNet(nn.Module):
    """Per-cell impurity logits (N, 1, H, W) from pooled scene_planes (N, 4, H, W), H and W multiples of 4.
    width: channels at the finest level (twice that at the coarser ones)."""

    def __init__(self, width: int = 24):
        super().__init__()
        self.width = int(width)

        def block(a, b, dilation=1):
            return nn.Sequential(nn.Conv2d(a, b, 3, padding=dilation, dilation=dilation), nn.BatchNorm2d(b),
                                 nn.ReLU(inplace=True))
        self.high = nn.Sequential(block(4, width), block(width, width))
        self.mid = nn.Sequential(nn.MaxPool2d(2), block(width, 2 * width), block(2 * width, 2 * width))
        self.low = nn.Sequential(nn.MaxPool2d(2), block(2 * width, 2 * width, 2),
                                 block(2 * width, 2 * width, 4), block(2 * width, 2 * width, 8))
        self.up_low = nn.Upsample(scale_factor=2, mode="bilinear", align_corners=False)
        self.merge_mid = block(4 * width, 2 * width)
        self.up_mid = nn.Upsample(scale_factor=2, mode="bilinear", align_corners=False)
        self.merge_high = block(3 * width, width)
        self.out = nn.Conv2d(width, 1, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        high = self.high(x)
        mid = self.mid(high)
        low = self.low(mid)
        mid = self.merge_mid(torch.cat([mid, self.up_low(low)], 1))
        return self.out(self.merge_high(torch.cat([high, self.up_mid(mid)], 1)))

    def probability(self, color: np.ndarray, height: np.ndarray, objects: np.ndarray) -> np.ndarray:
        """(H, W) float32 in [0, 1]: each cell's impurity probability (module docstring; arguments as
        scene_planes). Runs on the CPU without gradients; the network is put in eval mode."""
        objects = np.asarray(objects, dtype=bool)
        rows, cols = objects.shape
        x = torch.from_numpy(pooled(scene_planes(color, height, objects)))[None]
        self.eval()
        with torch.no_grad():
            small = torch.sigmoid(self(x))[0, 0].numpy()
        full = cv2.resize(small, (small.shape[1] * POOL, small.shape[0] * POOL),
                          interpolation=cv2.INTER_LINEAR)
        return np.ascontiguousarray(full[:rows, :cols], dtype=np.float32)


def network_dict(net: ImpurityNet, provenance: str) -> dict:
    """What write_network stores: the weights in float16 (half the file; the probabilities move by < 1e-3)."""
    return {"format_version": FORMAT_VERSION, "width": net.width, "provenance": provenance,
            "state_dict": {k: v.half() if v.is_floating_point() else v for k, v in net.state_dict().items()}}


def write_network(net: ImpurityNet, path, provenance: str) -> None:
    """Save `net` to `path` (network_dict's format)."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(network_dict(net, provenance), path)


def shipped_network_path() -> pathlib.Path:
    """The shipped weights (checkpoints.shipped_path): the package's share dir when it has them, else the
    source tree's SHIPPED_NETWORK."""
    return shipped_path(SHIPPED_NETWORK.name)


def read_network(path=None) -> ImpurityNet:
    """The network in `path` (None: shipped_network_path()), float32, in eval mode. NetworkFileError when the
    file is missing, unreadable, of another format version or does not match ImpurityNet's shapes."""
    path = pathlib.Path(path) if path is not None else shipped_network_path()
    data = read_versioned(path, "impurity network", FORMAT_VERSION, NetworkFileError)
    net = ImpurityNet(int(data.get("width", 24)))
    weights = data.get("state_dict", {})
    check_tensors(weights, net.state_dict(), f"impurity network {path}", "ImpurityNet", NetworkFileError)
    net.load_state_dict({k: v.float() if v.is_floating_point() else v for k, v in weights.items()})
    net.provenance = str(data.get("provenance", ""))
    return net.eval()
