"""Ninth session, tuning data only: why the shipped verifier misses visible impurities. For each visible
scene it misses: the rank of the first salient region on the impurity (none: saliency never puts it among
the regions), that region's probability, and whether the scene is colour-separable.

    python docs/experiments_s9/misses.py own|fresh|shared
"""
import collections
import sys

sys.path.insert(0, "scripts")
import numpy as np  # noqa: E402

import calibrate_attention as ca  # noqa: E402
from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend, salient_regions, scene_maps  # noqa: E402
from impurity_attention.core.verifier import candidate_features, default_verifier  # noqa: E402

which = sys.argv[1] if len(sys.argv) > 1 else "own"
if which == "fresh":
    records = evaluation.load_records(ca.CACHE / "palettes_tuning_fresh.npz")
elif which == "own":
    records = ca.collect_palettes("tuning", own_layouts=True)
else:
    records = ca.collect_palettes("tuning")
params = AttentionParams()
model = default_verifier()
kinds = collections.Counter()
rows = []
for record in records:
    if record.category() != "visible":
        continue
    verdict = evaluation.judge(record, attend(record.color, record.height, params))
    if verdict.success:
        kinds["found"] += 1
        continue
    objects = record.height > params.density.occupied_height
    saliency, conspicuity = scene_maps(record.color, objects, params)
    regions = salient_regions(saliency, objects, params)
    ranks = [k for k, r in enumerate(regions) if np.any(r.mask & record.visible_target_cells)]
    rank = ranks[0] if ranks else None
    separable = evaluation.colour_separable(record)
    probability = None
    if rank is not None and rank < 3:
        features = candidate_features(record.color, record.height, objects, conspicuity, regions)
        if features[rank][1] is not None:
            probability = float(model.probability(features[rank][1][None])[0])
    kind = ("not a region" if rank is None else "rank > 3" if rank >= 3 else
            f"rank {rank + 1}, below threshold")
    kinds[kind + (" (separable)" if separable else " (not separable)")] += 1
    rows.append((record.palette, record.scenario, record.seed, kind, probability, separable,
                 int(record.visible_target_cells.sum()), len(regions)))
print(f"{which}: {sum(kinds.values())} visible scenes")
for kind, count in kinds.most_common():
    print(f"  {kind:40s} {count}")
for row in sorted(rows):
    probability = "-" if row[4] is None else f"{row[4]:.2f}"
    print(f"  {row[0]:12s} {row[1]:11s} {row[2]:6d} {row[3]:24s} p {probability:5s} separable {row[5]!s:5s} "
          f"visible cells {row[6]:4d} regions {row[7]}")
