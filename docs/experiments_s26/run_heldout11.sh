#!/bin/bash
# Twenty-sixth session: the eleventh held-out set (splits.py, fixed in 581591d before any of it was rendered),
# measured once with the shipped attention and network and the picking loop's known product. Perception
# (palette-evaluate) and the exposure check run side by side (one core each), then picking under `cell`,
# the default palette on the set's 100 picking seeds, and picking under `none`. Writes into runs/s26/ (scripts/measure_heldout_set.sh).
#
#     docs/experiments_s26/run_heldout11.sh          # about 75 min on 2 cores
cd "$(dirname "$0")/../.." && exec scripts/measure_heldout_set.sh runs/s26 heldout11 910900000 911000000
