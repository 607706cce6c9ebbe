"""Thirteenth session, tuning palettes only: where do the shipped attention's misses on visible impurities
come from? Per visible scene: found; the impurity among the verifier's TOP_REGIONS candidates but not taken;
among the salient regions further down; in no salient region at all. Split by the colour oracle
(evaluation.colour_separable) and by a clipped view (heightmap.clipped_view).

    python docs/experiments_s13/candidates.py [500|600 ...]     # fresh tuning palette sets (default 500 600)
"""
import sys
from collections import Counter

import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
import fresh_tuning_palettes as fresh  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import (  # noqa: E402
    AttentionMode,
    AttentionParams,
    attend,
    salient_regions,
    sanitize,
    scene_maps,
)
from impurity_attention.core.heightmap import clipped_view  # noqa: E402
from impurity_attention.core.verifier import TOP_REGIONS  # noqa: E402


def outcome(record, params) -> str:
    color, height = sanitize(record.color, record.height)
    objects = height > params.density.occupied_height
    output = attend(record.color, record.height, params)
    target = record.visible_target_cells
    if output.mode == AttentionMode.TARGET and np.any(output.target_mask & target):
        return "found"
    saliency, _ = scene_maps(color, objects, params)
    regions = salient_regions(saliency, objects, params)
    on = [bool(np.any(r.mask & target)) for r in regions]
    if any(on[:TOP_REGIONS]):
        return "candidate, not taken" + (" (TARGET elsewhere)" if output.mode == AttentionMode.TARGET else "")
    if any(on):
        return "salient, below the top 3"
    return "in no salient region"


def main() -> None:
    firsts = [int(a) for a in sys.argv[1:]] or [500, 600]
    params = AttentionParams()
    for first in firsts:
        records = [r for r in fresh.fresh_records(first, 60) if r.category() == "visible"]
        table = Counter()
        for record in records:
            key = outcome(record, params)
            separable = "separable" if evaluation.colour_separable(record) else "not separable"
            objects = record.height > params.density.occupied_height
            clipped = "clipped" if clipped_view(record.color, objects) else "unclipped"
            table[(key, separable, clipped)] += 1
        print(f"== random-{first} ... {first + 59}: {len(records)} visible scenes")
        for (key, separable, clipped), n in sorted(table.items()):
            print(f"  {n:4d}  {key:40s} {separable:14s} {clipped}")


if __name__ == "__main__":
    main()
