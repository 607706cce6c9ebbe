#!/usr/bin/env bash
# pytest, where "no tests collected" (exit 5) is a failure, not a silent pass.
set -uo pipefail
python -m pytest "$@"
rc=$?
if [ "$rc" -eq 5 ]; then
  echo "pytest collected no tests: failing on purpose" >&2
  exit 1
fi
exit "$rc"
