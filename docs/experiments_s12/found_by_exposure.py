"""Twelfth session, measurement only: held-out found rate split by whether the heightmap node warns about the
view's exposure (heightmap.exposure_problem: clipped or nearly black) and by whether a per-cell colour oracle
separates the impurity (evaluation.colour_separable), with the shipped attention.

    python docs/experiments_s12/found_by_exposure.py [acceptance|retired|tuning]
"""
import collections
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402
from impurity_attention.core.heightmap import exposure_problem  # noqa: E402


def main() -> None:
    split = sys.argv[1] if len(sys.argv) > 1 else "acceptance"
    params = AttentionParams()
    counts = collections.Counter()
    separable = collections.Counter()
    palettes = collections.defaultdict(set)
    for record in ca.collect_palettes(split):
        if record.category() != "visible":
            continue
        warned = exposure_problem(record.color, record.height) is not None
        found = bool(evaluation.judge(record, attend(record.color, record.height, params)).success)
        counts[warned, found] += 1
        separable[bool(evaluation.colour_separable(record)), found] += 1
        if warned:
            palettes[record.palette].add(found)
    for warned, name in ((False, "views the node does not warn about"), (True, "views it warns about")):
        total = counts[warned, True] + counts[warned, False]
        print(f"{split}: {name}: impurity found {counts[warned, True]}/{total} "
              f"({100 * counts[warned, True] / max(total, 1):.1f} %)")
    print(f"palettes with a warned view: {', '.join(sorted(palettes))}")
    for kind, name in ((True, "colour-separable"), (False, "not colour-separable")):
        total = separable[kind, True] + separable[kind, False]
        print(f"{split}: {name} scenes: impurity found {separable[kind, True]}/{total} "
              f"({100 * separable[kind, True] / max(total, 1):.1f} %)")


if __name__ == "__main__":
    main()
