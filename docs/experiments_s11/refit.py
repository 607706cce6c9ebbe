"""Eleventh session, tuning data only: the region verifier refitted with colour features that leave clipped
cells out (verifier.colour_cells), against the shipped model, read on the default palette's wide exposure
tuning set (exposure_wide.py) and on the fitting scenes through attend().

    python docs/experiments_s11/refit.py shipped        # the shipped model and features (no fit)
    python docs/experiments_s11/refit.py old-features   # refit with every cell compared (as shipped)
    python docs/experiments_s11/refit.py unclipped      # refit with clipped cells left out
    python docs/experiments_s11/refit.py unclipped --exposed-palettes all|separable  # + palettes x0.5, x2
    python docs/experiments_s11/refit.py unclipped --default-extra   # + the default palette's exposure scenes

Each writes runs/s11/refit_<name>.json (the model) beside its printout. The `unclipped` variants need
verifier.colour_cells, which is in commit 6e681af only (the refit was not kept: docs/experiments.md, eleventh
section); run them from a git worktree of 6e681af.
"""
import argparse
import dataclasses
import json
import pathlib
import sys

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s11")
import calibrate_attention as ca  # noqa: E402
import exposure_wide  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core import verifier as verifier_module  # noqa: E402
from impurity_attention.core.attention import AttentionParams  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("variant", choices=("shipped", "old-features", "unclipped"))
    parser.add_argument("--exposed-palettes", choices=("all", "separable"), default=None,
                        help="fit also on every tuning palette's shared-layout scenes at x0.5 and x2 "
                             "(separable: only those whose visible impurity colour_separable still tells)")
    parser.add_argument("--default-extra", action="store_true",
                        help="fit also on ca.collect_exposure_scenes (the default palette, seeds 35000+) at "
                             "x0.5, x1, x2: what verifier-fit now does")
    parser.add_argument("--no-check", action="store_true", help="skip the check on the fitting scenes")
    args = parser.parse_args()
    if args.variant in ("shipped", "old-features"):
        verifier_module.MIN_UNCLIPPED_CELLS = 10**9  # every cell compared, as before this session
    params = AttentionParams()
    name = (args.variant + (f"-exposed-{args.exposed_palettes}" if args.exposed_palettes else "")
            + ("-default-extra" if args.default_extra else ""))
    if args.variant == "shipped":
        model = verifier_module.default_verifier()
    else:
        plain = ca.rule_sweep_records

        def more_records(exposed=True):
            records, default = plain(exposed)
            extra = []
            if args.exposed_palettes:
                extra = [r.exposed(e) for r in records
                         if r.palette not in ("blocks", "") and "@" not in r.palette
                         for e in ca.EXPOSURES if e != 1.0]
                if args.exposed_palettes == "separable":
                    extra = [r for r in extra if r.category() != "visible" or evaluation.colour_separable(r)]
            return records + extra, default
        ca.rule_sweep_records = more_records
        model = ca.verifier_fit(params, write=False, own_layouts=True, check=False,
                                exposure_scenes=args.default_extra)
        if not args.no_check:
            tried = dataclasses.replace(params, verifier=model)
            for half, scenes in (("shared layouts", plain()[0]),
                                 ("own layouts", ca.collect_palettes("tuning", own_layouts=True))):
                print(f" verifier, {half} (the shipped model's fitting scenes):")
                ca.print_palette_rates(ca.palette_rates(scenes, tried), per_palette=False)
    pathlib.Path("runs/s11").mkdir(parents=True, exist_ok=True)
    pathlib.Path(f"runs/s11/refit_{name}.json").write_text(json.dumps(dataclasses.asdict(model), indent=1))
    tried = dataclasses.replace(params, verifier=model)
    print(f"== exposure_wide tuning set (default palette, seeds {exposure_wide.SEED_BASE}+), model {name}")
    exposure_wide.report(exposure_wide.collect(), tried)


if __name__ == "__main__":
    main()
