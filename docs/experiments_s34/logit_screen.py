"""Thirty-fourth session, tuning data only: H4L, the screen's H4 network with its two verifier features read
as log-odds (docs/experiments.md, thirty-fourth section). No retraining and no new rows: the cnn_mean and
cnn_high columns of H4's cached rows (runs/s33/cnn_h4_rows.npz and cnn_h4_rows_default_fit.npz, written by
`cnn_screen.py --variant H4 [--with-default-fit]`) become log(p / (1 - p)) of p clipped to [LOW, 1 - LOW],
then cnn_screen's two readings run on them unchanged.

    python docs/experiments_s34/logit_screen.py [--with-default-fit [--guard]] \
        [--rows runs/s33/cnn_h5_rows.npz]
"""
import argparse
import pathlib
import sys

import numpy as np

sys.path[:0] = ["scripts", "docs/experiments_s11", "docs/experiments_s12", "docs/experiments_s13",
                "docs/experiments_s33"]
import cnn_screen as cs  # noqa: E402
import excluded_screen as ex  # noqa: E402

ROWS = pathlib.Path("runs/s33/cnn_h4_rows.npz")
LOW = 1e-4
MODELS = {"A shipped fifteen": cs.FEATURES, "H4L fifteen + log-odds": cs.FEATURES + cs.CNN}


def log_odds(parts: tuple) -> tuple:
    """table()'s parts with the last two feature columns (cnn_mean, cnn_high) as log-odds."""
    features = parts[0].copy()
    p = np.clip(features[:, -2:], LOW, 1.0 - LOW)
    features[:, -2:] = np.log(p / (1.0 - p))
    return (features, *parts[1:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--with-default-fit", action="store_true")
    parser.add_argument("--rows", type=pathlib.Path, default=ROWS,
                        help="a variant's cached rows (cnn_screen.py --variant ...; default H4's)")
    parser.add_argument("--guard", action="store_true",
                        help="with --with-default-fit: the threshold also at 1 %% of the default "
                             "palette's clean "
                             "scenes (H4LD)")
    args = parser.parse_args()
    data = np.load(args.rows)
    models = {f"{name.replace('H4L', args.rows.stem.split('_')[1].upper() + 'L')}": chosen
              for name, chosen in MODELS.items()}
    sets = {name: log_odds(tuple(data[f"{name}_{k}"] for k in ex.PARTS))
            for name in ("fresh", "check", "x0.5", "x1", "x2")}
    if args.with_default_fit:
        cache = args.rows.with_name(args.rows.stem + "_default_fit.npz")
        assert cache.exists(), f"{cache}: run cnn_screen.py --variant ... --with-default-fit first"
        cs.with_default_fit(sets, 1, transform=log_odds, models=models, cache=cache, guard=args.guard)
    else:
        cs.plain_reading(sets, models)


if __name__ == "__main__":
    main()
