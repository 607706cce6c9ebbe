"""Fully convolutional action-value function (FCAVF, paper section 5.2.1) sized for a 2-core CPU.

Inputs (our reading of section 5.2.1 and Fig. 6). The attention module gives a 112 x 112 colour crop
I_ccd / I_tcd, the matching height crop and a mask (the salient region m_t, or all ones for an occluded
region). From them we build the paper's two orthographic RGB-D heightmaps:
  - target-centric heightmap: the crop itself (colour + height);
  - target-mask heightmap: the crop "and" the mask, i.e. colour and height kept only on the target's
    pixels, zero elsewhere (with the all-one mask of an occluded region it equals the first).
"The RGB channels of the heightmaps combined with the channel-wise cloned depth channel are two
separate inputs into the two DenseNet towers": a colour tower sees the RGB of both heightmaps
(6 channels) and a depth tower the height of both, each cloned to three channels as in VPG (6
channels). Their features are concatenated channel-wise and two 1x1 convolution layers per primitive
(push, grasp) give one Q map each, bilinearly upsampled back to the crop size.

Rotations. The inputs are rotated into 16 orientations so that direction yaw_i = i * 2 pi / 16 points
along +column ("push to the right", grasp fingers closing along the row); the Q maps are rotated back.
16 rotations x 2 primitives = 32 Q maps, the argmax is the action.

Why not DenseNet-121: no pretrained ImageNet weights exist here (no torchvision CPU build, no
download) and a DenseNet-121 pair at 320^2 costs about 2.4 s per decision on this machine. Each tower
is instead two small dense blocks (DenseNet connectivity: every layer sees all earlier feature maps)
at stride 4 and 8, about 0.1 M parameters in all; GroupNorm instead of BatchNorm because DQN updates
here are single samples, where batch statistics mean nothing.

Valid pixels. A rotated 112^2 crop loses its corners, so Q values are only defined inside the
inscribed disk of the crop (radius 56 px = 112 mm around the target); `valid_action_mask` says where.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from impurity_common import cell
from impurity_common.enums import PrimitiveKind

# Input normalisation: colour to about [-2, 2], heights (m) to about [0, 3] for our 2-10 cm blocks.
COLOR_MEAN = 0.5
COLOR_STD = 0.25
HEIGHT_SCALE = 0.03  # m per unit
# index of the primitive in Q-map tensors (enums.PrimitiveKind: the values of Primitive.PUSH/GRASP)
PUSH, GRASP = int(PrimitiveKind.PUSH), int(PrimitiveKind.GRASP)
# Rotations per forward pass: 4 measured fastest here (benchmarks/bench_policy.py: 16 at once, 4 or 1).
INFERENCE_CHUNK = 4


@dataclass(frozen=True)
class NetworkConfig:
    """Everything that fixes tensor shapes; stored in checkpoints and checked on load."""

    crop_size: int = cell.CROP_SIZE
    num_rotations: int = cell.NUM_ROTATIONS
    stem_channels: int = 24
    growth: int = 16  # channels each dense layer adds
    block_layers: tuple = (3, 3)  # dense layers in block 1 (stride 4) and block 2 (stride 8)
    head_channels: int = 64
    groups: int = 4  # GroupNorm groups

    def to_dict(self) -> dict:
        d = asdict(self)
        d["block_layers"] = list(self.block_layers)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> NetworkConfig:
        d = dict(d)
        d["block_layers"] = tuple(d["block_layers"])
        return cls(**d)


def _norm(channels: int, groups: int) -> nn.Module:
    return nn.GroupNorm(math.gcd(groups, channels), channels)


class DenseLayer(nn.Module):
    def __init__(self, in_channels: int, growth: int, groups: int):
        super().__init__()
        self.body = nn.Sequential(_norm(in_channels, groups), nn.ReLU(inplace=True),
                                  nn.Conv2d(in_channels, growth, 3, padding=1, bias=False))

    def forward(self, x):
        return torch.cat([x, self.body(x)], dim=1)


def dense_block(in_channels: int, layers: int, growth: int, groups: int) -> tuple:
    modules = []
    for i in range(layers):
        modules.append(DenseLayer(in_channels + i * growth, growth, groups))
    return nn.Sequential(*modules), in_channels + layers * growth


class Tower(nn.Module):
    """6-channel image -> features at stride 8 (stem s2, max-pool s2, dense block, transition s2,
    dense block)."""

    def __init__(self, config: NetworkConfig, in_channels: int = 6):
        super().__init__()
        c = config.stem_channels
        self.stem = nn.Sequential(nn.Conv2d(in_channels, c, 3, stride=2, padding=1, bias=False),
                                  _norm(c, config.groups), nn.ReLU(inplace=True),
                                  nn.MaxPool2d(2))
        self.block1, c = dense_block(c, config.block_layers[0], config.growth, config.groups)
        transition = c // 2
        self.transition = nn.Sequential(_norm(c, config.groups), nn.ReLU(inplace=True),
                                        nn.Conv2d(c, transition, 1, bias=False), nn.AvgPool2d(2))
        self.block2, c = dense_block(transition, config.block_layers[1], config.growth, config.groups)
        self.out_channels = c

    def forward(self, x):
        return self.block2(self.transition(self.block1(self.stem(x))))


class Head(nn.Module):
    """The paper's "2 additional convolutional layers" (1x1, as in VPG) -> one Q map."""

    def __init__(self, in_channels: int, config: NetworkConfig):
        super().__init__()
        self.body = nn.Sequential(_norm(in_channels, config.groups), nn.ReLU(inplace=True),
                                  nn.Conv2d(in_channels, config.head_channels, 1, bias=False),
                                  _norm(config.head_channels, config.groups), nn.ReLU(inplace=True),
                                  nn.Conv2d(config.head_channels, 1, 1))

    def forward(self, x):
        return self.body(x)


def rotation_grid(yaws: torch.Tensor, size: int, inverse: bool) -> torch.Tensor:
    """Sampling grids that rotate (N, C, size, size) images about their centre.

    Image coordinates (col, row) are (x, y) of base_link up to an offset (cell.pixel_to_base), so a
    yaw rotation is a plain rotation of (col, row). Forward (inverse=False): output pixel u samples the
    input at R(yaw) u, so the input's direction yaw lands on +col. Inverse: the way back.
    """
    cos, sin = torch.cos(yaws), torch.sin(yaws)
    if inverse:
        sin = -sin
    theta = torch.stack([torch.stack([cos, -sin, torch.zeros_like(cos)], dim=1),
                         torch.stack([sin, cos, torch.zeros_like(cos)], dim=1)], dim=1)
    return F.affine_grid(theta, [len(yaws), 1, size, size], align_corners=False)


def rotation_yaws(indices) -> torch.Tensor:
    return torch.tensor([cell.rotation_yaw(int(i)) for i in indices], dtype=torch.float32)


class QNetwork(nn.Module):
    """Compact inputs (B, 5, S, S) already rotated -> (B, 2, S, S) Q maps (push, grasp) in the rotated
    frame; `q_maps` does the rotations.

    The compact input holds the 5 distinct planes (RGB, target mask, height); the towers' 6-channel
    inputs are expanded from it after rotation, so rotating costs 5 planes instead of 12."""

    def __init__(self, config: NetworkConfig = NetworkConfig()):
        super().__init__()
        self.config = config
        self.color_tower = Tower(config)
        self.depth_tower = Tower(config)
        features = self.color_tower.out_channels + self.depth_tower.out_channels
        self.push_head = Head(features, config)
        self.grasp_head = Head(features, config)
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, nonlinearity="relu")
                if m.bias is not None:
                    nn.init.zeros_(m.bias)

    @staticmethod
    def tower_inputs(compact: torch.Tensor) -> tuple:
        """(B, 5, S, S) -> colour (B, 6, S, S): RGB of the target-centric and of the target-mask
        heightmap; depth (B, 6, S, S): the height of each, cloned to three channels."""
        rgb, mask, height = compact[:, 0:3], compact[:, 3:4], compact[:, 4:5]
        masked_height = height * mask
        color = torch.cat([rgb, rgb * mask], dim=1)
        depth = torch.cat([height, height, height, masked_height, masked_height, masked_height], dim=1)
        return color, depth

    def forward(self, compact: torch.Tensor) -> torch.Tensor:
        color, depth = self.tower_inputs(compact)
        features = torch.cat([self.color_tower(color), self.depth_tower(depth)], dim=1)
        q = torch.cat([self.push_head(features), self.grasp_head(features)], dim=1)
        return F.interpolate(q, size=compact.shape[-2:], mode="bilinear", align_corners=False)

    def q_maps(self, compact: torch.Tensor, rotations=None,
               chunk: int | None = INFERENCE_CHUNK) -> torch.Tensor:
        """Unrotated compact input (1, 5, S, S) -> Q maps (R, 2, S, S) in the crop frame for the
        given rotation indices (default all); `chunk` rotations per forward pass (None: all at once)."""
        rotations = list(range(self.config.num_rotations)) if rotations is None else list(rotations)
        size = compact.shape[-1]
        outputs = []
        step = chunk or len(rotations)
        for start in range(0, len(rotations), step):
            yaws = rotation_yaws(rotations[start:start + step]).to(compact.device)
            rotated = F.grid_sample(compact.expand(len(yaws), -1, -1, -1),
                                    rotation_grid(yaws, size, inverse=False), align_corners=False)
            q_rotated = self(rotated)
            back = rotation_grid(yaws, size, inverse=True)
            outputs.append(F.grid_sample(q_rotated, back, align_corners=False))
        return torch.cat(outputs, dim=0)


def resolve_device(name: str = "cpu") -> torch.device:
    """The torch device for a device option: "cpu", "cuda", "cuda:N", or "auto" (CUDA when present,
    else the CPU). ValueError naming the option when the device is unknown or absent."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError as error:
        raise ValueError(f"device '{name}' is not a torch device (cpu, cuda, cuda:N or auto)") from error
    if device.type not in ("cpu", "cuda"):
        raise ValueError(f"device '{name}': only cpu, cuda, cuda:N and auto are supported")
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device '{name}': this torch build or machine has no CUDA (use cpu or auto)")
    return device


def network_inputs(color_crop: np.ndarray, height_crop: np.ndarray, mask: np.ndarray) -> torch.Tensor:
    """Attention crops -> the compact input (1, 5, S, S): normalised RGB, target mask (0/1), scaled
    height. QNetwork.tower_inputs turns it into the two towers' 6-channel inputs."""
    size = color_crop.shape[0]
    if color_crop.shape != (size, size, 3) or height_crop.shape != (size, size) or mask.shape != (size, size):
        raise ValueError(f"crops must be (S, S, 3), (S, S), (S, S); got {color_crop.shape}, "
                         f"{height_crop.shape}, {mask.shape}")
    planes = np.empty((5, size, size), dtype=np.float32)
    planes[0:3] = ((color_crop.astype(np.float32) / 255.0 - COLOR_MEAN) / COLOR_STD).transpose(2, 0, 1)
    planes[3] = mask > 0
    planes[4] = np.nan_to_num(height_crop.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0) / HEIGHT_SCALE
    return torch.from_numpy(planes)[None]


def valid_action_mask(size: int = cell.CROP_SIZE, margin: float = 1.0) -> np.ndarray:
    """(S, S) bool: pixels every rotation sees (the crop's inscribed disk, `margin` px inside)."""
    centre = (size - 1) / 2.0
    rows, cols = np.mgrid[0:size, 0:size]
    return (rows - centre) ** 2 + (cols - centre) ** 2 <= (size / 2.0 - margin) ** 2


def parameter_count(net: nn.Module) -> int:
    return sum(p.numel() for p in net.parameters())
