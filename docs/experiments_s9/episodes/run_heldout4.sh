#!/bin/bash
# issue 17, ninth session: the fourth held-out set measured once with the shipped attention and network, on
# evaluation seeds fixed before it was rendered (900500000 + k). The held-out group cycles through all 28
# palettes (generalisation.group_palettes), 56 episodes per scenario: each palette twice per scenario.
# The same eval_cli run through scripts/run_heldout.sh (the body it had when it ran is in git history; like
# that body, it measures the held-out group splits.py names today).
root=$(cd "$(dirname "$0")/../../.." && pwd)
exec "$root/scripts/run_heldout.sh" "$root/runs/s9/heldout4" 900500000 56
