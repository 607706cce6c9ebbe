"""The scenes a calibration fits on: the default and tuning palettes on tuning scene seeds, rendered in the
simulator once and cached, or views recorded elsewhere (.npz scene records, impurity_attention's
evaluation.save_records).

A palette's scenes follow PLAN, each palette on layouts of its own: seed = seed_base + the row's offset
(the scenes of every palette in the rows before) + the palette's index x the row's count + i.
"""

from __future__ import annotations

import pathlib
import sys

import numpy as np

from .. import splits

# (scenario, num_targets, scenes per palette): visible impurities, scenes without one, and heaps with and
# without a hidden impurity (19 scenes per palette)
PLAN = (("random", 2, 6), ("challenging", 2, 4), ("random", 0, 3), ("challenging", 0, 2),
        ("invisible", 0, 1), ("invisible", 2, 2), ("invisible", 1, 1))
NUM_OBJECTS = 20
SEED_BASE = 20_000  # tuning scene seeds
RANDOM_PALETTES = 8  # random tuning palettes beside the named ones (default --palettes)
TUNING_GROUPS = ("default", "tuning")  # the palette splits a calibration may fit on


class CalibrationRefused(ValueError):
    """Data outside the tuning split was given to a calibration; the message names it."""


def check_palettes(palettes) -> None:
    """Raise CalibrationRefused naming the first palette that is neither the default nor a tuning one."""
    for name in palettes:
        try:
            group = splits.palette_group(name)
        except ValueError as error:
            raise CalibrationRefused(f"palette {name!r}: {error}") from error
        if group not in TUNING_GROUPS:
            raise CalibrationRefused(f"palette {name!r} is in the {group} split: a calibration fits on the "
                                     f"default and tuning palettes only")


def check_seeds(seeds) -> None:
    """Raise CalibrationRefused naming the first scene seed outside splits.TUNING_SEED_RANGE."""
    for seed in seeds:
        if seed not in splits.TUNING_SEED_RANGE:
            split = splits.scene_seed_split(seed)
            where = f"in the {split} split" if split else "outside the tuning seeds"
            tuning = splits.TUNING_SEED_RANGE
            raise CalibrationRefused(f"scene seed {seed} is {where}: a calibration fits on tuning seeds "
                                     f"{tuning.start}..{tuning.stop - 1} only")


def default_palettes(lightness: int = splits.TUNING_LIGHTNESS_COUNT) -> list:
    """The default palette, the named tuning ones, RANDOM_PALETTES random ones and `lightness` lightness ones
    (splits.tuning_palettes)."""
    return splits.tuning_palettes(RANDOM_PALETTES, lightness)


def plan_scenes(palettes, seed_base: int = SEED_BASE, scale: int = 1) -> list:
    """(palette, scenario, seed, num_targets) of PLAN (each row's count x scale) for every palette, palette by
    palette (module docstring for the seeds). Raises CalibrationRefused for a palette or seed outside the
    tuning split."""
    palettes = list(palettes)
    check_palettes(palettes)
    counts = [count * scale for *_, count in PLAN]
    offsets = np.concatenate([[0], np.cumsum([len(palettes) * count for count in counts])])
    scenes = [(palette, scenario, seed_base + int(offsets[row]) + number * counts[row] + i, targets)
              for number, palette in enumerate(palettes)
              for row, (scenario, targets, _) in enumerate(PLAN) for i in range(counts[row])]
    check_seeds([seed for _, _, seed, _ in scenes])
    return scenes


def render(wanted: list, cache: pathlib.Path | None = None, progress: bool = True) -> list:
    """Scene records (impurity_attention.core.evaluation.SceneRecord) of `wanted` ((palette, scenario, seed,
    num_targets)) in that order: those in the `cache` .npz, the others rendered (with a tqdm bar; a scene
    the simulator cannot build is reported on stderr and left out) and the cache rewritten."""
    from tqdm import tqdm

    from impurity_attention.core import evaluation

    cached = {}
    if cache is not None and cache.exists():
        cached = {(r.palette, r.scenario, r.seed, r.num_targets): r for r in evaluation.load_records(cache)}
    missing = [w for w in wanted if w not in cached]
    if missing:
        from ur5_driver_sim.core.world import CellWorld

        world = CellWorld(mode="floating")
        try:
            for palette, scenario, seed, targets in tqdm(missing, desc="render scenes", unit="scene",
                                                         disable=not progress):
                try:
                    record = evaluation.record_from_world(world, scenario, seed, targets, NUM_OBJECTS,
                                                          palette=palette)
                except RuntimeError as error:
                    print(f"skipped {palette} {scenario} seed {seed}: {error}", file=sys.stderr)
                    continue
                cached[(palette, scenario, seed, targets)] = record
        finally:
            world.close()
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            evaluation.save_records(cache, list(cached.values()))
    return [cached[w] for w in wanted if w in cached]


def load_views(paths) -> list:
    """Scene records of recorded .npz files; CalibrationRefused if one is of a palette or seed outside the
    tuning split."""
    from impurity_attention.core import evaluation

    records = [record for path in paths for record in evaluation.load_records(path)]
    check_palettes({record.palette or splits.DEFAULT_PALETTE for record in records})
    check_seeds([record.seed for record in records])
    return records


def add_options(parser) -> None:
    """The options choosing the scenes (network, verifier, colour-reference)."""
    parser.add_argument("--palettes", nargs="+", default=None, metavar="NAME",
                        help="default and tuning palettes to render (default: the default palette, the named "
                             f"tuning palettes, random-0 ... random-{RANDOM_PALETTES - 1} and lightness-0 "
                             "... lightness-<N - 1>, N of --lightness-palettes)")
    parser.add_argument("--lightness-palettes", type=int, default=splits.TUNING_LIGHTNESS_COUNT, metavar="N",
                        help="lightness tuning palettes among the default ones (impurities unlike the "
                             f"product mainly in lightness; default {splits.TUNING_LIGHTNESS_COUNT})")
    parser.add_argument("--scale", type=int, default=1, help="scenes per palette: 19 x this")
    parser.add_argument("--seed-base", type=int, default=SEED_BASE, help="the first tuning scene seed")
    parser.add_argument("--limit", type=int, default=None, help="only the first N scenes (a quick check)")
    parser.add_argument("--views", type=pathlib.Path, nargs="+", default=None, metavar="NPZ",
                        help="fit on these recorded scene records instead of rendering")
    parser.add_argument("--cache", type=pathlib.Path, default=None,
                        help="rendered scenes are kept here (.npz; default OUT/scenes.npz)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def scenes_of(args) -> list:
    """The scene records the options ask for (rendered or read)."""
    if args.views:
        return load_views(args.views)[:args.limit]
    wanted = plan_scenes(args.palettes or default_palettes(args.lightness_palettes), args.seed_base,
                         args.scale)[:args.limit]
    return render(wanted, args.cache or args.out / "scenes.npz", progress=not args.no_progress)
