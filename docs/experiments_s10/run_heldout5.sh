#!/bin/bash
# issue 17, tenth session: the fifth held-out set measured once with the shipped attention and network, on
# evaluation seeds fixed before it was rendered (900600000 + k). The held-out group cycles through all 28
# palettes (generalisation.group_palettes), 56 episodes per scenario: each palette twice per scenario.
# The same eval_cli run through scripts/run_heldout.sh (the body it had when it ran is in git history; like
# that body, it measures the held-out group splits.py names today).
root=$(cd "$(dirname "$0")/../.." && pwd)
exec "$root/scripts/run_heldout.sh" "$root/runs/s10/heldout5" 900600000 56
