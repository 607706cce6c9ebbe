#!/bin/bash
# Thirty-first session: the fourteenth held-out set (splits.py, fixed before any of it was rendered),
# measured once with the shipped attention and network, the picking loop's known product (its near miss left
# out), the cell preset with grasp_square_to_faces and the picking loop's stall look. Perception (palette-evaluate) and the exposure check run side by side (one core each), then picking under `cell`,
# the default palette on the set's 100 picking seeds, and picking under `none`. Writes into runs/s31/ (scripts/measure_heldout_set.sh).
#
#     docs/experiments_s31/run_heldout14.sh          # 40 min on 2 cores in the thirty-second session
cd "$(dirname "$0")/../.." && exec scripts/measure_heldout_set.sh runs/s31 heldout14 916900000 917000000
