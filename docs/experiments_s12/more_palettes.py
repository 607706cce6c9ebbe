"""Twelfth session, tuning data only: does fitting the region verifier on more tuning palettes make it find
more on tuning palettes it was not fitted on?

The shipped model is fitted on rule-sweep's scenes and the own-layout scenes of random-0 ... 95 and the tuning
named palettes (`calibrate_attention.py verifier-fit --own-layouts`). This adds EXTRA random tuning palettes
(random-192 ..., unused so far: random-96 ... 191 served the tenth session's episodes), each with layouts of
its own (seeds 80000 + 2000 x the plan's row + palette number x the row's count + i), refits the same way, and
measures both models on random-500 ... 559 (fresh_tuning_palettes.py; nothing fitted or chosen on them).

    python docs/experiments_s12/more_palettes.py collect [extra]   # render (cached in runs/perception)
    python docs/experiments_s12/more_palettes.py fit [extra]       # refit, then both models on random-500+
"""
import dataclasses
import json
import pathlib
import sys

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
import calibrate_attention as ca  # noqa: E402
from fresh_tuning_palettes import fresh_records  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402

FIRST_EXTRA = 192
SEED_BASE = 80_000
FRESH_FIRST, FRESH_COUNT = 500, 60


def extra_records(count: int) -> list:
    palettes = [f"random-{FIRST_EXTRA + number}" for number in range(count)]
    wanted = ca.palette_scenes(palettes, lambda row, number, scenes: SEED_BASE + 2000 * row + number * scenes)
    return ca.render_cached(ca.CACHE / f"palettes_extra{FIRST_EXTRA}.npz", wanted,
                            f"extra tuning palettes {FIRST_EXTRA}+")


def main() -> None:
    command = sys.argv[1]
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 200
    extra = extra_records(count)
    if command == "collect":
        return
    shipped_records = ca.rule_sweep_records

    def with_extra(exposed: bool = True):
        records, default = shipped_records(exposed)
        return records + extra, default

    ca.rule_sweep_records = with_extra
    params = AttentionParams()
    model = ca.verifier_fit(params, write=False, own_layouts=True, check=False)
    out = pathlib.Path(f"runs/s12/verifier_extra{count}.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(dataclasses.asdict(model)))
    print(f"wrote {out}")
    fresh = fresh_records(FRESH_FIRST, FRESH_COUNT)
    for name, tried in (("shipped", params), (f"refit with {count} more palettes",
                                               dataclasses.replace(params, verifier=model))):
        print(f"== random-{FRESH_FIRST} ... {FRESH_FIRST + FRESH_COUNT - 1}, {name}")
        ca.print_palette_rates(ca.palette_rates(fresh, tried), per_palette=False)


if __name__ == "__main__":
    main()
