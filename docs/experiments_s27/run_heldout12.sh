#!/bin/bash
# Twenty-seventh session: the twelfth held-out set (splits.py, fixed before any of it was rendered),
# measured once with the shipped attention and network and the picking loop's known product, its near miss left
# out. Perception (palette-evaluate) and the exposure check run side by side (one core each), then picking under `cell`,
# the default palette on the set's 100 picking seeds, and picking under `none`. Writes into runs/s27/ (scripts/measure_heldout_set.sh).
#
#     docs/experiments_s27/run_heldout12.sh          # about 75 min on 2 cores
cd "$(dirname "$0")/../.." && exec scripts/measure_heldout_set.sh runs/s27 heldout12 912900000 913000000
