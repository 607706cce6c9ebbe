"""Twenty-ninth session: grasps at upright cubes (within 2 cm of a target, tilt at most 10 deg) in push_out.py
episodes recorded with --grasp-geometry, lifted / grasps by the closing axis's offset from the cube's faces
(0 = square on two faces, 45 = across the corners), in the twenty-fourth section's bins.

    python docs/experiments_s29/cube_bins.py EPISODES.jsonl [...]
"""
import json
import sys

EDGES = (0.0, 7.5, 15.0, 22.5, 30.0, 37.5, 45.01)

for path in sys.argv[1:]:
    bins = [[0, 0] for _ in EDGES[:-1]]
    with open(path) as lines:
        for line in lines:
            for g in json.loads(line).get("grasps", []):
                if g.get("target_m") is None or g["target_m"] > 0.02 or g.get("g_shape") != "cube":
                    continue
                if g.get("g_tilt") is None or g["g_tilt"] > 10:
                    continue
                closing = g["g_closing"] % 90
                offset = min(closing, 90 - closing)
                for i in range(len(EDGES) - 1):
                    if EDGES[i] <= offset < EDGES[i + 1]:
                        bins[i][0] += int(g["lifted"])
                        bins[i][1] += 1
    print(path.split("/")[-1], " | ".join(f"{lifted}/{grasps}" for lifted, grasps in bins))
