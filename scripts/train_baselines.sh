#!/usr/bin/env bash
# `make train-baselines`: trains the networks the evaluation compares ours with (VPG, which S-VPG also
# runs, and the ablations No-TSD, No-OI, No-T), all four at once with one torch thread each and the
# same wall-clock budget, then exports each to src/impurity_learning/checkpoints/<method>.pt and copies
# its Fig. 9 plot and summary to docs/training/<method>/ (the full log stays in runs/<method>/log.csv).
# Rerunning resumes every run from its checkpoint.
#   BASELINE_HOURS  wall-clock budget per run (default 1.3)
#   BASELINE_ITERS  iteration cap per run (default 12000, the same cap as ours)
#   BASELINE_METHODS  subset, e.g. "vpg no_t"
set -euo pipefail
cd "$(dirname "$0")/.."
hours=${BASELINE_HOURS:-1.3}
iterations=${BASELINE_ITERS:-12000}
methods=${BASELINE_METHODS:-vpg no_tsd no_oi no_t}
pids=()
for method in $methods; do
  log="runs/train_${method}.log"
  mkdir -p runs
  echo "train-baselines: $method for up to ${hours} h / ${iterations} iterations (progress: tail -f $log)"
  python -m impurity_learning.train_cli --method "$method" --run-dir "runs/$method" --seed 0 \
    --iterations "$iterations" --max-hours "$hours" --threads 1 \
    --export "src/impurity_learning/checkpoints/${method}.pt" > "$log" 2>&1 &
  pids+=($!)
done
status=0
for pid in "${pids[@]}"; do wait "$pid" || status=1; done
for method in $methods; do
  mkdir -p "docs/training/$method"
  cp "runs/$method/success.png" "docs/training/$method/"
  # the run's JSON summary is the last {...} block the CLI printed
  python - "$method" <<'PY'
import json, pathlib, re, sys
method = sys.argv[1]
text = pathlib.Path(f"runs/train_{method}.log").read_text()
blocks = re.findall(r"^\{\n.*?^\}", text, flags=re.S | re.M)
if blocks:
    pathlib.Path(f"docs/training/{method}/summary.json").write_text(blocks[-1] + "\n")
    print(f"train-baselines: {method}: " + ", ".join(f"{k} {v}" for k, v in json.loads(blocks[-1]).items()))
else:
    print(f"train-baselines: {method}: no summary in runs/train_{method}.log", file=sys.stderr)
PY
done
exit $status
