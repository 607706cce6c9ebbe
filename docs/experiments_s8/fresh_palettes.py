"""Eighth session, tuning data only: tuning random palettes nothing was ever chosen on (random-96 ... 191,
within splits.TUNING_RANDOM_SEEDS), each on scenes of its own (seeds as collect_palettes(own_layouts=True)
with palette numbers after the 101 used ones). Do the shipped verifier's and the rule's tuning figures hold
on palettes drawn afresh from the same generator? Cached in runs/perception/palettes_tuning_fresh.npz.

    python docs/experiments_s8/fresh_palettes.py
"""
import sys
sys.path.insert(0, "scripts")
import numpy as np
from tqdm import tqdm
import calibrate_attention as ca
from impurity_attention.core import evaluation
from impurity_attention.core.attention import AttentionParams

FRESH = [f"random-{s}" for s in range(96, 192)]
path = ca.CACHE / "palettes_tuning_fresh.npz"
cached = {}
if path.exists():
    cached = {(r.palette, r.scenario, r.seed, r.num_targets): r for r in evaluation.load_records(path)}
wanted = []
for number, palette in enumerate(FRESH, start=101):
    for index, (scenario, targets, count) in enumerate(ca.PALETTE_PLAN):
        base = ca.OWN_LAYOUT_SEED_BASE + 1000 * index + number * count
        wanted += [(palette, scenario, base + i, targets) for i in range(count)]
missing = [w for w in wanted if w not in cached]
if missing:
    from ur5_driver_sim.core.world import CellWorld
    world = CellWorld(mode="floating")
    for palette, scenario, seed, targets in tqdm(missing, desc="render fresh tuning palettes"):
        try:
            cached[(palette, scenario, seed, targets)] = evaluation.record_from_world(
                world, scenario, seed, targets, ca.NUM_OBJECTS, palette=palette)
        except RuntimeError as error:
            print(f"  skipped {palette} {scenario} {seed}: {error}", file=sys.stderr)
    world.close()
    evaluation.save_records(path, list(cached.values()))
records = [cached[w] for w in wanted if w in cached]
for decision in ("rule", "verifier"):
    rates = ca.palette_rates(records, AttentionParams(decision=decision))
    found = np.array([np.mean(v["visible"]) for v in rates.values()])
    print(f"fresh tuning palettes, {decision}: <= 50 % found {int(np.sum(found <= 0.5))}, <= 80 % "
          f"{int(np.sum(found <= 0.8))} of {len(found)}")
    ca.print_palette_rates(rates, per_palette=False)
