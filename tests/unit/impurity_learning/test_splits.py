"""The split that is kept (splits.py): tuning, held-out and retired palettes never overlap, and a rotated
held-out set is retired, never returned to tuning."""

import ast
import pathlib
import re

import pytest
from source_scan import module_constants, option_default

from impurity_learning import splits
from ur5_driver_sim.core.appearance import PALETTES


def test_every_named_palette_of_the_split_exists_in_the_simulator():
    for name in (*splits.TUNING_NAMED, *splits.HELD_OUT_NAMED, *splits.RETIRED_NAMED):
        assert name in PALETTES


def test_groups_do_not_overlap():
    named = [set(splits.TUNING_NAMED), set(splits.HELD_OUT_NAMED), set(splits.RETIRED_NAMED)]
    assert all(not (a & b) for i, a in enumerate(named) for b in named[i + 1:])
    seeds = [set(splits.TUNING_RANDOM_SEEDS) | set(splits.TUNING_FRESH_RANDOM_SEEDS),
             set(splits.HELD_OUT_RANDOM_SEEDS),
             *(set(s) for _, s in splits.RETIRED_SETS), set(splits.TRAINING_RANDOM_SEEDS)]
    assert all(not (a & b) for i, a in enumerate(seeds) for b in seeds[i + 1:])


def test_the_held_out_set_is_held_out_and_every_earlier_set_is_retired():
    assert {splits.palette_group(p) for p in splits.held_out_palettes()} == {"held_out"}
    assert {splits.palette_group(p) for p in splits.retired_palettes()} == {"retired"}
    assert len(splits.retired_palettes(random_count=2)) == sum(len(n) + 2 for n, _ in splits.RETIRED_SETS)
    assert splits.palette_group(f"{splits.HELD_OUT_NAMED[1]}@x2") == "held_out"  # exposure suffix ignored



def test_the_readme_names_the_current_held_out_set_and_every_retired_one():
    """README "Appearance": the split paragraph lists the held-out and retired palettes by hand; it must
    follow splits.py when a set is rotated."""
    text = (pathlib.Path(__file__).resolve().parents[3] / "README.md").read_text()
    paragraph = text[text.index("**The split**"):text.index("<!-- appearance:start -->")]
    held_out, retired = paragraph.split('now "retired"', 1)
    for name in splits.HELD_OUT_NAMED:
        assert f"`{name}`" in held_out and f"`{name}`" not in retired
    first, last = splits.HELD_OUT_RANDOM_SEEDS[0], splits.HELD_OUT_RANDOM_SEEDS[-1]
    assert f"`random-{first}…{last}`" in held_out
    for names, seeds in splits.RETIRED_SETS:
        assert all(f"`{name}`" in retired for name in names)
        assert f"`random-{seeds[0]}…{seeds[-1]}`" in retired

def test_the_fresh_tuning_palettes_are_tuning_palettes():
    first, last = splits.TUNING_FRESH_RANDOM_SEEDS[0], splits.TUNING_FRESH_RANDOM_SEEDS[-1]
    assert {splits.palette_group(f"random-{s}") for s in (first, last)} == {"tuning"}
    with pytest.raises(ValueError, match="no group"):
        splits.palette_group(f"random-{last + 1}")
    assert splits.tuning_random_palettes(first, 2) == [f"random-{first}", f"random-{first + 1}"]
    assert splits.tuning_random_palettes(998, 2) == ["random-998", "random-999"]
    with pytest.raises(ValueError, match="random-999 ... 1000: not all tuning palettes"):
        splits.tuning_random_palettes(999, 2)
    with pytest.raises(ValueError, match="not all tuning palettes"):
        splits.tuning_random_palettes(last, 2)


def test_a_palette_outside_the_split_is_refused():
    with pytest.raises(ValueError, match="no group"):
        splits.palette_group("random-10000000")


def test_held_out_perception_scenes_are_evaluation_seeds_of_their_own_below_the_picking_runs():
    # palette-evaluate's PALETTE_PLAN: 7 rows of at most 6 scenes. Every palette's scenes are its own, never a
    # tuning seed, and below the set's picking run (HELD_OUT_LAYOUT_SEED_BASE + 900 000 + k,
    # docs/experiments.md thirteenth section)
    palettes = len(splits.held_out_palettes())
    seeds = [splits.held_out_layout_seed(row, k, 6) + i for row in range(7) for k in range(palettes)
             for i in range(6)]
    assert len(set(seeds)) == len(seeds)
    assert min(seeds) == splits.HELD_OUT_LAYOUT_SEED_BASE >= splits.EVAL_SEED_BASE
    assert not any(seed in splits.TUNING_SEED_RANGE for seed in seeds)
    assert max(seeds) < splits.HELD_OUT_LAYOUT_SEED_BASE + 900_000



# The table of tuning scene seed blocks (splits.TUNING_SEED_BLOCKS). The scripts are read as text with ast,
# not imported (calibrate_attention and the experiments pull in the renderer): their seed bases and plans
# are module-level literals.
ROOT = pathlib.Path(__file__).resolve().parents[3]
def verdict_tuning_base() -> int:
    """calibrate_verdict.seeds_of's tuning base (`base = 50_000 if split == "tuning" else ...`)."""
    tree = ast.parse((ROOT / VERDICT).read_text())
    seeds_of = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "seeds_of")
    assign = next(n for n in ast.walk(seeds_of)
                  if isinstance(n, ast.Assign) and isinstance(n.value, ast.IfExp))
    return ast.literal_eval(assign.value.body)


def shell_runs(path: str) -> list:
    """(seed base, episodes per scenario) of every eval_cli command of a shell script."""
    runs = []
    for line in (ROOT / path).read_text().replace("\\\n", " ").splitlines():
        if "--seed-base" in line:
            counts = [int(n) for n in re.findall(r"--(?:group-)?episodes (\d+)", line)]
            runs.append((int(re.search(r"--seed-base (\d+)", line).group(1)), max(counts, default=20)))
    return runs


CA, VERDICT = "scripts/calibrate_attention.py", "scripts/calibrate_verdict.py"
RULES, EPISODE_END = "scripts/check_rules.py", "scripts/calibrate_episode_end.py"
S7 = "docs/experiments_s7/last_look/run_truth_counted.sh"
S8 = "docs/experiments_s8/episodes/run_truth_counted.sh"
S9 = "docs/experiments_s9/episodes/run_truth_counted.sh"
FINAL_VIEWS, LAST_LOOK = "docs/experiments_s10/final_views.py", "docs/experiments_s10/last_look_episodes.py"
CONFIRM, MORE = "docs/experiments_s12/confirm.py", "docs/experiments_s12/more_palettes.py"
FRESH_LAYOUTS, PUSH_OUT = "docs/experiments_s13/fresh_layouts.py", "docs/experiments_s14/push_out.py"
LOOP_VIEWS = "docs/experiments_s17/loop_views.py"
FRESH_S18 = "docs/experiments_s18/run_fresh.sh"
STALL_S18 = "docs/experiments_s18/run_stall.sh"
RIDGE_S19 = "docs/experiments_s19/run_ridge.sh"
ORIENTED_S20 = "docs/experiments_s20/run_oriented.sh"


def own_layout_seeds(base: int, palettes: int, row_stride: int, first: int = 0) -> list:
    """Seeds of PALETTE_PLAN with scenes of each palette's own: base + stride x row + number x count + i
    for palette numbers first ... first + palettes - 1."""
    plan = module_constants(ROOT / CA)["PALETTE_PLAN"]
    return [base + row_stride * row + number * count + i for number in range(first, first + palettes)
            for row, (_, _, count) in enumerate(plan) for i in range(count)]


def exposure_seeds(base: int, scale: float) -> list:
    """collect_exposure_scenes(base, scale)'s seeds: base + 1000 x row + i."""
    plan = module_constants(ROOT / CA)["EXPOSURE_PLAN"]
    return [base + 1000 * row + i for row, (_, _, count) in enumerate(plan)
            for i in range(int(count * scale))]


def planned_seeds() -> list:
    """(user, the seeds of one plan) for the plans of TUNING_SEED_BLOCKS, recomputed from the scripts'
    constants and the recorded runs' counts (docs/*)."""
    ca, rules = module_constants(ROOT / CA), module_constants(ROOT / RULES)
    end = module_constants(ROOT / EPISODE_END)
    rules_episodes = option_default(ROOT / RULES, "--episodes")
    plan = ca["PLAN"]
    tuning_palettes = len(splits.tuning_palettes(ca["PALETTE_RANDOM_COUNT"]["tuning"]))
    final_views = module_constants(ROOT / FINAL_VIEWS)
    push_out = module_constants(ROOT / PUSH_OUT)["SEED_BASE"]
    return [
        (CA, [ca["SEED_BASE"]["tuning"] + 100 * row + i for row, (*_, tuning, _) in enumerate(plan)
              for i in range(tuning)]),
        (CA, [ca["SEED_BASE"]["acceptance"] + 100 * row + i for row, (*_, acceptance) in enumerate(plan)
              for i in range(acceptance)]),
        (CA, own_layout_seeds(ca["OWN_LAYOUT_SEED_BASE"], tuning_palettes, 1000)),
        # experiments_s8/fresh_palettes.py: random-96 ... 191, numbered after the 101 tuning palettes
        ("docs/experiments_s8/fresh_palettes.py",
         own_layout_seeds(ca["OWN_LAYOUT_SEED_BASE"], 96, 1000, first=tuning_palettes)),
        (CA, exposure_seeds(ca["EXPOSURE_CHECK_SEED_BASE"], 1)),
        (CA, exposure_seeds(ca["EXPOSURE_FIT_SEED_BASE"], 1)),
        # docs/experiments.md, eleventh session: exposure_wide.py report --seed-base 40000 --count-scale 2
        ("docs/experiments_s11/exposure_wide.py", exposure_seeds(40_000, 2)),
        (CONFIRM, exposure_seeds(module_constants(ROOT / CONFIRM)["FRESH_SEED_BASE"], 2)),
        (VERDICT, [verdict_tuning_base() + k for k in range(40)]),  # docs/verdict/tuning_sweep.txt
        (EPISODE_END, [end["SEED_BASE"]["tuning"] + 100 * index + k  # docs/episode_end/*.txt: --seeds 30
                       for index in range(len(end["SCENES"])) for k in range(30)]),
        *((RULES, [rules["SEED_BASE"] + 1000 * index + k for k in range(rules_episodes)])
          for index in range(len(rules["SCENARIOS"]))),
        *((path, [base + k for k in range(episodes)])
          for path in (S7, S8, S9) for base, episodes in shell_runs(path)),
        ("docs/experiments.md", [70_000 + k for k in range(20)]),  # the sixth session's runs/s6_diag
        (FINAL_VIEWS, [final_views["SEED_BASE"] + 10 * number + k  # named tuning palettes, random-96 ... 191
                       for number in range(len(splits.TUNING_NAMED) + 96)
                       for k in range(len(final_views["SCENARIOS"]))]),
        (LAST_LOOK, [module_constants(ROOT / LAST_LOOK)["DEFAULT_SEED_BASE"] + k for k in range(20)]),
        # `more_palettes.py collect 200`: random-192 ... 391; fresh_layouts.py's default: random-700 ... 759
        (MORE, own_layout_seeds(module_constants(ROOT / MORE)["SEED_BASE"], 200, 2000)),
        (FRESH_LAYOUTS,
         own_layout_seeds(module_constants(ROOT / FRESH_LAYOUTS)["LAYOUT_SEED_BASE"], 60, 800)),
        # push_out.py: the fourteenth session's 200 invisible episodes; the fifteenth's --start 200 (400
        # invisible) and --start 600 (200 challenging), one block; the sixteenth's --start 800 (grasp records)
        (PUSH_OUT, [push_out + k for k in range(200)]),
        (PUSH_OUT, [push_out + k for k in range(200, 800)]),
        (PUSH_OUT, [push_out + k for k in range(800, 1000)]),
        (PUSH_OUT, [19_000 + k for k in range(600)]),  # --seed-base 19000 (sixteenth session)
        (PUSH_OUT, [11_000 + k for k in range(400)]),  # --seed-base 11000 (seventeenth session)
        (FRESH_S18, [12_000 + k for k in range(300)]),  # push_out.py --seed-base 12000 (eighteenth session)
        (STALL_S18, [13_000 + k for k in range(300)]),  # push_out.py --seed-base 13000 (eighteenth session)
        (RIDGE_S19, [14_000 + k for k in range(300)]),  # push_out.py --seed-base 14000 (nineteenth session)
        (RIDGE_S19, [15_000 + k for k in range(300)]),  # run_ridge.sh ... 2: --seed-base 15000 (the revision)
        (RIDGE_S19, [16_000 + k for k in range(300)]),  # run_ridge.sh ... 3: --seed-base 16000 (the second)
        (ORIENTED_S20, [17_000 + k for k in range(300)]),  # push_out.py --seed-base 17000 (twentieth session)
        # twentieth session: exposure_wide.py report --seed-base 2000 --count-scale 2 [--model ...]
        ("docs/experiments_s11/exposure_wide.py", exposure_seeds(2_000, 2)),
        # network-fit's further views, packed: random-800 ... 999 x PALETTE_PLAN's scenes; EXPOSURE_PLAN twice
        (CA, [ca["NETWORK_PALETTE_SEED_BASE"] + k
              for k in range(200 * sum(count for *_, count in ca["PALETTE_PLAN"]))]),
        (CA, [ca["NETWORK_DEFAULT_SEED_BASE"] + k
              for k in range(2 * sum(count for *_, count in ca["EXPOSURE_PLAN"]))]),
        # loop_views.py collect: invisible k < 160, challenging --start 200 (80), random --start 400 (80)
        (LOOP_VIEWS, [module_constants(ROOT / LOOP_VIEWS)["SEED_BASE"] + k
                      for k in [*range(160), *range(200, 280), *range(400, 480)]]),
    ]


def test_every_tuning_seed_block_is_a_stretch_of_the_tuning_range_with_a_user():
    assert splits.TUNING_SEED_BLOCKS
    for block in splits.TUNING_SEED_BLOCKS:
        assert splits.TUNING_SEED_RANGE.start <= block.start < block.stop <= splits.TUNING_SEED_RANGE.stop
        assert (ROOT / block.user).is_file(), block.user
        assert block.note


@pytest.mark.parametrize(("user", "seeds"), planned_seeds(), ids=lambda v: v if isinstance(v, str) else "")
def test_every_plan_is_a_block_of_its_user_from_its_first_seed_to_its_last(user, seeds):
    extent = (min(seeds), max(seeds) + 1)
    assert extent in [(b.start, b.stop) for b in splits.TUNING_SEED_BLOCKS if b.user == user]


# (path, constant, key): the scripts' seed bases that are tuning seeds
SEED_BASES = [(CA, "SEED_BASE", "tuning"), (CA, "SEED_BASE", "acceptance"),
              (CA, "OWN_LAYOUT_SEED_BASE", None), (CA, "EXPOSURE_FIT_SEED_BASE", None),
              (CA, "EXPOSURE_CHECK_SEED_BASE", None), (RULES, "SEED_BASE", None),
              (EPISODE_END, "SEED_BASE", "tuning"), (FINAL_VIEWS, "SEED_BASE", None),
              (LAST_LOOK, "DEFAULT_SEED_BASE", None), (CONFIRM, "FRESH_SEED_BASE", None),
              (MORE, "SEED_BASE", None), (FRESH_LAYOUTS, "LAYOUT_SEED_BASE", None),
              (PUSH_OUT, "SEED_BASE", None), (LOOP_VIEWS, "SEED_BASE", None),
              (CA, "NETWORK_PALETTE_SEED_BASE", None), (CA, "NETWORK_DEFAULT_SEED_BASE", None)]


@pytest.mark.parametrize(("path", "name", "key"), SEED_BASES)
def test_a_scripts_seed_base_starts_a_block_of_its_own(path, name, key):
    base = module_constants(ROOT / path)[name]
    base = base if key is None else base[key]
    assert base in splits.TUNING_SEED_RANGE
    assert base in [b.start for b in splits.tuning_seed_blocks(base) if b.user == path]


def test_the_verdict_calibrations_and_the_shell_scripts_seed_bases_start_blocks_of_their_own():
    assert verdict_tuning_base() in [b.start for b in splits.TUNING_SEED_BLOCKS if b.user == VERDICT]
    for path in (S7, S8, S9):
        assert shell_runs(path)
        for base, _ in shell_runs(path):
            assert base in [b.start for b in splits.TUNING_SEED_BLOCKS if b.user == path]


def test_every_script_with_a_tuning_seed_base_is_in_the_table():
    # a new experiment's `..._SEED_BASE = <tuning seed>` or `--seed-base <tuning seed>` needs a block
    found = set()
    for path in sorted([*ROOT.glob("scripts/*.py"), *ROOT.glob("docs/**/*.py")]):
        relative = str(path.relative_to(ROOT))
        for name, value in module_constants(path).items():
            values = value.values() if isinstance(value, dict) else [value]
            if name.endswith("SEED_BASE") and any(isinstance(v, int) and v in splits.TUNING_SEED_RANGE
                                                  for v in values):
                found.add(relative)
    for path in sorted([*ROOT.glob("scripts/*.sh"), *ROOT.glob("docs/**/*.sh")]):
        if any(int(base) in splits.TUNING_SEED_RANGE
               for base in re.findall(r"--seed-base (\d+)", path.read_text())):
            found.add(str(path.relative_to(ROOT)))
    assert {CA, RULES, S7, PUSH_OUT} <= found
    assert found - {b.user for b in splits.TUNING_SEED_BLOCKS} == set()


def test_tuning_seed_block_gives_every_block_holding_the_seed():
    for block in splits.TUNING_SEED_BLOCKS:
        assert block in splits.tuning_seed_blocks(block.start)
        assert block in splits.tuning_seed_blocks(block.stop - 1)
        assert block not in splits.tuning_seed_blocks(block.stop)
        assert block not in splits.tuning_seed_blocks(block.start - 1)
    # the seventh to ninth sessions re-ran one plan on purpose; check_rules' first seeds are among them
    assert {S7, S8, S9, RULES} <= {b.user for b in splits.tuning_seed_blocks(70_001)}
    assert splits.tuning_seed_blocks(-1) == splits.tuning_seed_blocks(splits.TUNING_SEED_RANGE.stop) == []


def test_free_tuning_seeds_and_the_blocks_cover_the_tuning_range_and_never_meet():
    free = splits.free_tuning_seeds()
    assert free and all(isinstance(stretch, range) and len(stretch) > 0 for stretch in free)
    # ascending, and each as long as it can be: two free stretches never touch
    assert all(a.stop < b.start for a, b in zip(free, free[1:], strict=False))
    for stretch in free:
        assert not any(b.start < stretch.stop and stretch.start < b.stop for b in splits.TUNING_SEED_BLOCKS)
        assert splits.tuning_seed_blocks(stretch.start) == splits.tuning_seed_blocks(stretch.stop - 1) == []
    used = {seed for block in splits.TUNING_SEED_BLOCKS for seed in range(block.start, block.stop)}
    free_seeds = {seed for stretch in free for seed in stretch}
    assert not free_seeds & used
    assert free_seeds | used == set(splits.TUNING_SEED_RANGE)
