"""Twelfth session, tuning seeds only: in views whose objects are clipped, how likely does the verifier find
its likeliest region, on clean scenes and on scenes with a visible impurity?

For every scene (default palette's exposure scenes at x1 and x2, and the tuning palettes' scenes at x1): the
clipped share (heightmap.exposure_problem's test), the likeliest region's probability, whether a TARGET there
would land on an impurity, and whether a heap would be chosen (no last look then). Rows go to a .jsonl.

    python docs/experiments_s12/clipped_probe.py exposure 35000 > runs/s12/probe_35000.jsonl
    python docs/experiments_s12/clipped_probe.py palettes tuning > runs/s12/probe_tuning.jsonl
"""
import dataclasses
import json
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402
from impurity_attention.core.density import find_clusters, select_occluded_region  # noqa: E402
from impurity_attention.core.heightmap import clipped_channel  # noqa: E402
from impurity_common.grid import HeightmapGrid  # noqa: E402

ANY = dataclasses.replace(AttentionParams(), verifier_threshold=1e-9, verifier_last_look=0.0)


def row(record) -> dict | None:
    category = record.category()
    if category not in ("visible", "no_impurity"):
        return None
    objects = record.height > ANY.density.occupied_height
    clipped = clipped_channel(record.color[objects])[1]
    output = attend(record.color, record.height, ANY)
    verdict = evaluation.judge(record, output)
    probability = float(output.reason.split("probability ")[1].split(" ")[0]) if "probability" in \
        output.reason else (1.0 if output.mode.name == "TARGET" else 0.0)
    heap = select_occluded_region(find_clusters(record.height, HeightmapGrid().resolution, ANY.density))
    return {"palette": record.palette, "scenario": record.scenario, "seed": record.seed,
            "category": category, "clipped": round(clipped, 3), "p": probability,
            "mode": output.mode.name, "on_impurity": bool(verdict.success) if category == "visible" else None,
            "heap": heap is not None}


def main() -> None:
    kind, which = sys.argv[1], sys.argv[2]
    if kind == "exposure":
        records = ca.collect_exposure_scenes(int(which), float(sys.argv[3]) if len(sys.argv) > 3 else 1.0)
        scenes = [r.exposed(e) for e in (1.0, 2.0) for r in records]
    else:
        scenes = ca.collect_palettes(which, own_layouts=len(sys.argv) > 3 and sys.argv[3] == "own")
    for scene in scenes:
        entry = row(scene)
        if entry is not None:
            print(json.dumps(entry), flush=True)


if __name__ == "__main__":
    main()
