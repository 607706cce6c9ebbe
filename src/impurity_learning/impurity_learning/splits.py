"""The split between what may be tuned on and what is only measured.

Thresholds, rules and models are chosen on TUNING palettes and TUNING scene seeds only. HELD-OUT palettes
and EVALUATION scene seeds are only measured (eval_cli, the generalisation table). Training draws its
appearances from the tuning palettes and random palettes of its own seed range, never from held-out ones.

Palettes are names for ur5_driver_sim.core.appearance.palette_named: a named palette's split is its
`split` field in ur5_driver_sim/data/palettes.yaml (default, tuning, held_out, spare); a random palette
`random-<seed>`'s split is the range of RANDOM_PALETTE_SEEDS holding its seed, a lightness palette
`lightness-<seed>`'s (impurities differing from the product mainly in lightness) that of
LIGHTNESS_PALETTE_SEEDS. Scene seeds are split by
SCENE_SEEDS. `palette_group` names the split of any palette. The scene sets beyond the paper's blocks
(ur5_driver_sim.core.scenes.SCENE_SETS) are split by seed the same way: `scene_set_seeds`.
"""

from __future__ import annotations

from typing import NamedTuple

from ur5_driver_sim.core.appearance import DEFAULT_PALETTE, LIGHTNESS_PREFIX, PALETTE_SPLITS, RANDOM_PREFIX


class SeedRange(NamedTuple):
    """Seeds `seeds` belong to split `split`; `meaning` says what they are for."""
    seeds: range
    split: str
    meaning: str


# Scene seeds (the layout of a scene: CellWorld.reset_scene's seed). Training plays seeds run seed x
# 1 000 003 + index (train.SCENE_SEED_STRIDE), a split of its own.
TUNING_SEED_RANGE = range(0, 100_000)
EVAL_SEED_BASE = 900_000_000
HELD_OUT_LAYOUT_SEED_BASE = 918_000_000
SCENE_SEEDS = (
    SeedRange(TUNING_SEED_RANGE, "tuning", "scenes thresholds, rules and models may be chosen on"),
    SeedRange(range(EVAL_SEED_BASE, HELD_OUT_LAYOUT_SEED_BASE), "evaluation",
              "make eval's episodes, EVAL_SEED_BASE + k: only measured"),
    SeedRange(range(HELD_OUT_LAYOUT_SEED_BASE, HELD_OUT_LAYOUT_SEED_BASE + 1_000_000), "evaluation",
              "the held-out palettes' perception scenes (held_out_layout_seed): only measured"),
)

# Scene sets (scenes.SCENE_SETS): tuning scenes SCENE_SET_TUNING_SEEDS (apart from the calibrate tool's
# 50 000 and 60 000 blocks), evaluation scenes EVAL_SEED_BASE + k as the paper's.
SCENE_SET_TUNING_SEEDS = range(70_000, 80_000)
SCENE_SET_SPLITS = ("tuning", "evaluation")


def scene_set_seeds(split: str, count: int, start: int = 0) -> list:
    """Scene seeds start ... start + count - 1 of `split` ("tuning": SCENE_SET_TUNING_SEEDS, "evaluation":
    EVAL_SEED_BASE + k). ValueError naming the split and its size when they do not fit."""
    if split not in SCENE_SET_SPLITS:
        raise ValueError(f"unknown split {split!r} (expected one of {', '.join(SCENE_SET_SPLITS)})")
    block = SCENE_SET_TUNING_SEEDS if split == "tuning" else SCENE_SEEDS[1].seeds
    if start < 0 or count < 0 or start + count > len(block):
        raise ValueError(f"{split} scene seeds {start} ... {start + count - 1}: the split holds "
                         f"{len(block)} seeds (0 ... {len(block) - 1})")
    return list(block[start:start + count])


# Random palettes random-<seed>, by seed.
TUNING_RANDOM_SEEDS = range(0, 1000)
TRAINING_RANDOM_SEEDS = range(10_000, 1_000_000)
HELD_OUT_RANDOM_SEEDS = range(1_005_000, 1_006_000)
RANDOM_PALETTE_SEEDS = (
    SeedRange(TUNING_RANDOM_SEEDS, "tuning", "random tuning palettes"),
    SeedRange(range(2_000_000, 2_010_000), "tuning", "more random tuning palettes"),
    SeedRange(TRAINING_RANDOM_SEEDS, "training", "drawn per scene while training (train.py)"),
    SeedRange(HELD_OUT_RANDOM_SEEDS, "held_out", "the held-out group's random palettes: only measured"),
    SeedRange(range(1000, 10_000), "spare", "neither tuned on nor part of the evaluation"),
    SeedRange(range(1_000_000, 1_005_000), "spare", "neither tuned on nor part of the evaluation"),
)
# Lightness palettes lightness-<seed>, by seed.
TUNING_LIGHTNESS_SEEDS = range(0, 1000)
HELD_OUT_LIGHTNESS_SEEDS = range(1_005_000, 1_006_000)
LIGHTNESS_PALETTE_SEEDS = (
    SeedRange(TUNING_LIGHTNESS_SEEDS, "tuning", "lightness tuning palettes"),
    SeedRange(HELD_OUT_LIGHTNESS_SEEDS, "held_out", "the lightness group's palettes: only measured"),
    SeedRange(range(1000, 1_005_000), "spare", "neither tuned on nor part of the evaluation"),
)
TUNING_LIGHTNESS_COUNT = 4  # lightness palettes among tuning_palettes' (the calibrate tools' default)
HELD_OUT_LIGHTNESS_COUNT = 48  # lightness palettes in the lightness group (held_out_lightness_palettes)
HELD_OUT_RANDOM_COUNT = 196  # random palettes in the held-out group (held_out_palettes' default)
TRAINING_EXPOSURE = (0.5, 2.0)  # exposure factor drawn log-uniformly while training

TUNING_NAMED = tuple(name for name, split in PALETTE_SPLITS.items() if split == "tuning")
HELD_OUT_NAMED = tuple(name for name, split in PALETTE_SPLITS.items() if split == "held_out")


def tuning_palettes(random_count: int = 8, lightness_count: int = TUNING_LIGHTNESS_COUNT) -> list:
    """The default palette, the named tuning palettes, random-0 ... random-<random_count - 1> and
    lightness-0 ... lightness-<lightness_count - 1>."""
    randoms = [f"{RANDOM_PREFIX}{s}" for s in TUNING_RANDOM_SEEDS[:random_count]]
    lightness = [f"{LIGHTNESS_PREFIX}{s}" for s in TUNING_LIGHTNESS_SEEDS[:lightness_count]]
    return [DEFAULT_PALETTE, *TUNING_NAMED, *randoms, *lightness]


def held_out_lightness_palettes(count: int = HELD_OUT_LIGHTNESS_COUNT) -> list:
    """The lightness group: the first `count` held-out lightness palettes."""
    return [f"{LIGHTNESS_PREFIX}{s}" for s in HELD_OUT_LIGHTNESS_SEEDS[:count]]


def tuning_random_palettes(start: int, count: int) -> list:
    """random-<start> ... random-<start + count - 1>. Raises ValueError naming the range unless every one is
    a tuning palette."""
    names = [f"{RANDOM_PREFIX}{seed}" for seed in range(start, start + count)]
    if any(palette_group(name) != "tuning" for name in names):
        raise ValueError(f"random-{start} ... {start + count - 1}: not all tuning palettes")
    return names


def held_out_palettes(random_count: int = HELD_OUT_RANDOM_COUNT) -> list:
    """The held-out group: the named held-out palettes, then the first `random_count` random ones."""
    return list(HELD_OUT_NAMED) + [f"{RANDOM_PREFIX}{s}" for s in HELD_OUT_RANDOM_SEEDS[:random_count]]


def held_out_layout_seed(row: int, palette_index: int, count: int) -> int:
    """The first perception scene seed of held-out palette `palette_index` (0-based, in held_out_palettes())
    in row `row` of a plan asking `count` scenes of it there: its scenes are seeds this + i, i < count.
    HELD_OUT_LAYOUT_SEED_BASE + 10 000 x row + palette_index x count."""
    return HELD_OUT_LAYOUT_SEED_BASE + 10_000 * row + palette_index * count


def palette_group(name: str) -> str:
    """The split of a palette name: "default", "tuning", "held_out", "spare" or "training" (suffixes such
    as @x<exposure> ignored). Raises ValueError for a name in no split."""
    base = name.split("@", 1)[0] or DEFAULT_PALETTE
    if base in PALETTE_SPLITS:
        return PALETTE_SPLITS[base]
    generated = ((RANDOM_PREFIX, RANDOM_PALETTE_SEEDS), (LIGHTNESS_PREFIX, LIGHTNESS_PALETTE_SEEDS))
    for prefix, blocks in generated:
        if base.startswith(prefix) and base[len(prefix):].isdigit():
            seed = int(base[len(prefix):])
            for block in blocks:
                if seed in block.seeds:
                    return block.split
    raise ValueError(f"palette {name!r} belongs to no split")


def scene_seed_split(seed: int) -> str | None:
    """"tuning" or "evaluation" for a scene seed of SCENE_SEEDS, None for any other."""
    return next((block.split for block in SCENE_SEEDS if seed in block.seeds), None)
