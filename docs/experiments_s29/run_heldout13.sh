#!/bin/bash
# Twenty-ninth session: the thirteenth held-out set (splits.py, fixed before any of it was rendered),
# measured once with the shipped attention and network, the picking loop's known product (its near miss left
# out) and the cell preset with grasp_square_to_faces. Perception (palette-evaluate) and the exposure check run side by side (one core each), then picking under `cell`,
# the default palette on the set's 100 picking seeds, and picking under `none`. Writes into runs/s29/ (scripts/measure_heldout_set.sh).
#
#     docs/experiments_s29/run_heldout13.sh          # about 75 min on 2 cores
cd "$(dirname "$0")/../.." && exec scripts/measure_heldout_set.sh runs/s29 heldout13 914900000 915000000
