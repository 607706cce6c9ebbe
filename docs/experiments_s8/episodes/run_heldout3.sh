#!/bin/bash
# issue 17, eighth session: the third held-out set measured once with the region verifier (shipped network),
# on the seventh session's seeds (900400000 + k), so each episode pairs with the rule's in docs/heldout3/
# The same eval_cli run through scripts/run_heldout.sh (the body it had when it ran is in git history; like
# that body, it measures the held-out group splits.py names today).
root=$(cd "$(dirname "$0")/../../.." && pwd)
exec "$root/scripts/run_heldout.sh" "$root/runs/s8_heldout3" 900400000 48
