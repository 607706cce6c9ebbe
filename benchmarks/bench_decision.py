"""Decision latency, side by side in one run: ours (heightmap + attention + 32 Q maps on the
112^2 crop) against a VPG-sized network (VPG's four DenseNet-121 trunks: colour and depth for push
and for grasp, on the 224^2 heightmap padded to 320^2, 16 rotations), both from the same sim frame.

    python benchmarks/bench_decision.py [--repeats 10] [--vpg-repeats 1] [--threads 2]

The DenseNet-121 trunks are built here (torchvision is not installable next to our torch pin) with
random weights: latency does not depend on the weights. Printed, never asserted.
"""

import argparse
import math
import os

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from timing import timed

from impurity_attention.core.attention import AttentionParams, attend
from impurity_attention.core.heightmap import HeightmapProjector
from impurity_common.grid import HeightmapGrid
from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
from impurity_policy.core.policy import MODE_NONE, Observation, Policy
from impurity_policy.core.rules import RulePipeline
from ur5_driver_sim.core.world import CellWorld

VPG_PADDED = 320  # VPG pads the 224^2 heightmap diagonally so rotations lose nothing
DENSENET121_BLOCKS = (6, 12, 24, 16)  # VPG uses torchvision's densenet121 features (1024 channels)
GROWTH, BOTTLENECK = 32, 4


class DenseLayer(nn.Sequential):
    def __init__(self, channels: int):
        super().__init__(nn.BatchNorm2d(channels), nn.ReLU(inplace=True),
                         nn.Conv2d(channels, BOTTLENECK * GROWTH, 1, bias=False),
                         nn.BatchNorm2d(BOTTLENECK * GROWTH), nn.ReLU(inplace=True),
                         nn.Conv2d(BOTTLENECK * GROWTH, GROWTH, 3, padding=1, bias=False))

    def forward(self, x):
        return torch.cat([x, super().forward(x)], 1)


def densenet121_features() -> nn.Sequential:
    layers = [nn.Conv2d(3, 64, 7, stride=2, padding=3, bias=False), nn.BatchNorm2d(64), nn.ReLU(inplace=True),
              nn.MaxPool2d(3, stride=2, padding=1)]
    channels = 64
    for i, count in enumerate(DENSENET121_BLOCKS):
        for _ in range(count):
            layers.append(DenseLayer(channels))
            channels += GROWTH
        if i < len(DENSENET121_BLOCKS) - 1:
            layers += [nn.BatchNorm2d(channels), nn.ReLU(inplace=True), nn.Conv2d(channels, channels // 2, 1,
                                                                                  bias=False),
                       nn.AvgPool2d(2, stride=2)]
            channels //= 2
    return nn.Sequential(*layers, nn.BatchNorm2d(channels))


class VPGSized(nn.Module):
    """VPG's forward pass shape: per rotation, rotate colour and depth, four DenseNet-121 trunks,
    a 2-layer head per primitive, upsample x16, rotate back."""

    def __init__(self):
        super().__init__()
        self.trunks = nn.ModuleList(densenet121_features() for _ in range(4))
        self.heads = nn.ModuleList(nn.Sequential(nn.BatchNorm2d(2048), nn.ReLU(), nn.Conv2d(2048, 64, 1),
                                                 nn.BatchNorm2d(64), nn.ReLU(), nn.Conv2d(64, 1, 1))
                                   for _ in range(2))

    @torch.no_grad()
    def q_maps(self, color: torch.Tensor, depth: torch.Tensor, rotations: int = 16) -> torch.Tensor:
        maps = []
        for r in range(rotations):
            angle = 2 * math.pi * r / rotations
            theta = torch.tensor([[[math.cos(angle), -math.sin(angle), 0.0],
                                   [math.sin(angle), math.cos(angle), 0.0]]])
            grid = F.affine_grid(theta, color.shape, align_corners=False)
            c = F.grid_sample(color, grid, align_corners=False)
            d = F.grid_sample(depth, grid, align_corners=False)
            per_primitive = []
            for p in range(2):
                features = torch.cat([self.trunks[2 * p](c), self.trunks[2 * p + 1](d)], 1)
                per_primitive.append(F.interpolate(self.heads[p](features), scale_factor=16, mode="bilinear"))
            maps.append(torch.cat(per_primitive, 1))
        return torch.stack(maps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--vpg-repeats", type=int, default=1, help="each is 64 DenseNet-121 passes")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--seed", type=int, default=900_000_000)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    print(f"torch {torch.__version__}, {args.threads} threads, load average {os.getloadavg()[0]:.2f}")

    world = CellWorld(mode="floating")
    world.reset_scene("random", seed=args.seed)
    frame = world.render()
    world.close()
    grid = HeightmapGrid()
    projector = HeightmapProjector(frame.intrinsics, frame.camera_pose, frame.depth.shape, grid)
    params = AttentionParams()
    policy = Policy.from_checkpoint(SHIPPED_CHECKPOINT, rules=RulePipeline.preset("cell"))  # as the cell

    def ours():
        maps = projector.project(frame.color, frame.depth)
        attention = attend(maps.color, maps.height, params, grid)
        obs = Observation.from_attention(attention, maps.height, grid)
        if obs.mode != MODE_NONE:
            policy.decide(obs)

    maps = projector.project(frame.color, frame.depth)
    pad = (VPG_PADDED - maps.height.shape[0]) // 2
    padded_color = np.pad(maps.color, ((pad, pad), (pad, pad), (0, 0)))
    color = torch.from_numpy(padded_color).permute(2, 0, 1)[None].float()
    depth = torch.from_numpy(np.pad(np.nan_to_num(maps.height), pad)).float()[None, None].expand(1, 3, -1, -1)
    vpg = VPGSized().eval()

    def vpg_decision():
        projector.project(frame.color, frame.depth)
        q = vpg.q_maps(color / 255.0, depth.contiguous())
        torch.argmax(q)

    ours_ms, _ = timed(ours, args.repeats, warmup=1)
    vpg_ms, _ = timed(vpg_decision, args.vpg_repeats, warmup=0)
    print(f"ours: heightmap + attention + 32 Q maps (112^2): p50 {np.median(ours_ms):7.0f} ms  "
          f"max {ours_ms.max():7.0f} ms  (n={args.repeats})")
    print(f"VPG-sized: heightmap + 4 DenseNet-121 trunks x 16 rotations (320^2): "
          f"p50 {np.median(vpg_ms):7.0f} ms  max {vpg_ms.max():7.0f} ms  (n={args.vpg_repeats})")
    print(f"ratio VPG-sized / ours (p50): {np.median(vpg_ms) / np.median(ours_ms):.1f}x")


if __name__ == "__main__":
    main()
