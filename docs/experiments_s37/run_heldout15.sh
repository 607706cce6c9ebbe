#!/bin/bash
# Thirty-seventh session: the fifteenth held-out set (splits.py, fixed before any of it was rendered),
# measured once with the shipped cell: attention's verifier reading the impurity network (its three thresholds
# matched to the earlier verifier's), the picking loop's known product and stall look, the cell preset.
# Perception (palette-evaluate) and the exposure check run side by side (one core each), then picking under
# `cell`, the default palette on the set's 100 picking seeds, and picking under `none`. Writes into runs/s37/
# (scripts/measure_heldout_set.sh).
#
#     docs/experiments_s37/run_heldout15.sh
cd "$(dirname "$0")/../.." && exec scripts/measure_heldout_set.sh runs/s37 heldout15 918900000 919000000
