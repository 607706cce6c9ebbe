"""Thirteenth session (needs commit 11a499c: TreeVerifier and verifier-fit --form trees, taken back after this
check failed): the criterion for the gradient-boosted verifier (docs/experiments.md, thirteenth
section), written before its check set was read. Fits the candidate (`verifier_fit(form="trees")` on the
shipped
rows: rule-sweep's scenes and the tuning palettes' own layouts), writes it to runs/s13/trees_model.py, and
measures, through attend(), the shipped model beside it on:
- random-700 ... 759, tuning layouts (fresh_tuning_palettes.fresh_records), and
- the default palette's exposure sets 30000+, 35000+, 40000+, 45000+ at x0.5, x1, x2.

    python docs/experiments_s13/trees_check.py fit          # fit + write runs/s13/trees_model.py
    python docs/experiments_s13/trees_check.py palettes     # random-700+
    python docs/experiments_s13/trees_check.py exposure     # the four exposure sets
"""
import collections
import dataclasses
import importlib.util
import pathlib
import sys

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
import calibrate_attention as ca  # noqa: E402
import fresh_tuning_palettes  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402

MODEL = pathlib.Path("runs/s13/trees_model.py")
EXPOSURE_SETS = (30000, 35000, 40000, 45000)


def candidate():
    spec = importlib.util.spec_from_file_location("impurity_attention.core.trees_model_s13", MODEL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.MODEL


def models() -> dict:
    return {"shipped": AttentionParams(),
            "trees": dataclasses.replace(AttentionParams(), verifier=candidate())}


def main() -> None:
    command = sys.argv[1]
    if command == "fit":
        verifier = ca.verifier_fit(AttentionParams(), write=False, own_layouts=True, check=False,
                                   form="trees")
        MODEL.parent.mkdir(parents=True, exist_ok=True)
        MODEL.write_text(ca.model_source(verifier))
        print(f"wrote {MODEL}")
    elif command == "palettes":
        records = fresh_tuning_palettes.fresh_records(700, 60)
        for name, params in models().items():
            print(f"== random-700 ... 759, {name}")
            ca.print_palette_rates(ca.palette_rates(records, params), per_palette=False)
    elif command == "exposure":
        for name, params in models().items():
            total = collections.Counter()
            for base in EXPOSURE_SETS:
                records = ca.collect_exposure_scenes(base)
                line = f"  {name:8s} {base}+:"
                for exposure in ca.EXPOSURES:
                    for record in records:
                        scene = record.exposed(exposure)
                        verdict = evaluation.judge(scene, attend(scene.color, scene.height, params))
                        if verdict.category in ("no_impurity", "visible"):
                            total[exposure, verdict.category, verdict.success] += 1
                    clean = total[exposure, "no_impurity", False]
                    line += f"  x{exposure:g} false TARGET {clean}"
                print(line + "  (running totals)")
            for exposure in ca.EXPOSURES:
                clean = total[exposure, "no_impurity", True] + total[exposure, "no_impurity", False]
                visible = total[exposure, "visible", True] + total[exposure, "visible", False]
                false = total[exposure, "no_impurity", False]
                print(f"  {name:8s} x{exposure:g}: false TARGET {false}/{clean}, "
                      f"impurity found {total[exposure, 'visible', True]}/{visible}")
    else:
        raise SystemExit(f"unknown command {command}: fit, palettes or exposure")


if __name__ == "__main__":
    main()
