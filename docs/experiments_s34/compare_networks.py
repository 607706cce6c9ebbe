"""Thirty-fourth session: does the trainer (impurity_learning.impurity_net_training, `calibrate_attention.py
network-fit`) give the screen's H4 network (docs/experiments_s33/cnn_screen.py --variant H4)? Reads both on
the default palette's exposure check set (seeds 30 000+, at x1; neither was trained on it) and prints the
largest and the mean difference of their per-cell probabilities over object cells.

    python docs/experiments_s34/compare_networks.py runs/impurity_net.pt /work/main/runs/s33/cnn_h4.pt
"""
import argparse
import pathlib
import sys

import numpy as np
import torch

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import sanitize  # noqa: E402
from impurity_attention.core.impurity_net import ImpurityNet, read_network  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("trained", type=pathlib.Path, help="network-fit's file (impurity_net format)")
    parser.add_argument("screen", type=pathlib.Path, help="the screen's state dict (cnn_screen.py's NET)")
    args = parser.parse_args()
    trained = read_network(args.trained)
    screen = ImpurityNet()
    screen.load_state_dict(torch.load(args.screen))
    screen.eval()
    largest, total, cells = 0.0, 0.0, 0
    records = ca.collect_exposure_scenes(ca.EXPOSURE_CHECK_SEED_BASE)
    for record in records:
        color, height = sanitize(record.color, record.height)
        objects = height > ca.AttentionParams().density.occupied_height
        difference = np.abs(trained.probability(color, height, objects)
                            - screen.probability(color, height, objects))[objects]
        largest = max(largest, float(difference.max(initial=0.0)))
        total, cells = total + float(difference.sum()), cells + int(objects.sum())
    print(f"{len(records)} views, {cells} object cells: largest difference {largest:.4f}, mean "
          f"{total / max(cells, 1):.5f}")


if __name__ == "__main__":
    main()
