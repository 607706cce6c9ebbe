"""The end of the search (impurity_policy.core.picking, EpisodeLimits.search_pushes), measured on fast-sim
episodes counted as a real cell counts (evaluate.PerceptionSimCell, the policy with the `cell` rules) with
the search never ended (search_pushes and low_heap_pushes SEARCH_UNENDED, impurity_area 0): each view
decided on is recorded with the mode attention decided on, the simulator's truth (targets remaining in the
workspace), the attended heap's height (m; 0 but for OCCLUDED_REGION) and the ground the episode had not
seen down to the table under material thicker than one piece (m^2, picking.TableMemory with
--piece-height).

A reveal is a run of OCCLUDED_REGION views in a row (pushes at heaps that showed no impurity) that ends in
a TARGET view while the truth still had a target remaining: a hidden impurity that showed after L pushes.
With search_pushes = K the loop ends the episode on the (K + 1)-th such view in a row, so a reveal of
L > K is left behind. A view answered NONE is not decided on and does not break a run (the loop's count
goes on past it), so a run that ends in NONE views at the episode's end, or at its end, is no reveal.

Share left behind at K: reveals with L > K over the impurities in all the episodes. Beside it the tool
replays each episode cut where search_pushes = K would have ended it: the impurities still in the
workspace there that the unended episode went on to pick (a reveal left behind can take later impurities
of its episode with it), and the actions saved.

Low heaps (EpisodeLimits.low_heap_pushes): a view at a heap lower than two pieces (2 x --piece-height) is
low. A reveal whose last L_low pushes were at low heaps is also left behind by low_heap_pushes < L_low; with
search_pushes chosen, the tool chooses the least low_heap_pushes that keeps the share within
--max-left-behind.

The table memory (EpisodeLimits.impurity_area): a reveal with a view in its run whose unexplored ground was
smaller than the impurity area is left behind by any search_pushes; every figure counts it (replays with
--impurity-area, recorded episodes with other values alike).

An episode file is JSON lines, one episode each, appended as episodes finish (a run that stops resumes).
"""

from __future__ import annotations

import itertools
import json
import math
import pathlib

from impurity_policy.core.episode import DEFAULT_PIECE_HEIGHT
from impurity_policy.core.picking import SearchRun

from .episodes import read_episodes
from .scenes import check_palettes, check_seeds

SEARCH_SEED_BASE = 70_000  # tuning scene seeds, SEARCH_SEED_BASE + k
SEARCH_SCENARIOS = ("random", "challenging", "invisible")  # the paper's, at its scene size
SEARCH_UNENDED = 1000  # search_pushes while measuring: the search never ends an episode
SEARCH_PUSHES_CAP = 20  # the largest search_pushes the tool chooses
EPISODES_FILE = "search_episodes.jsonl"
RESULT_FILE = "search_pushes.json"

OCCLUDED, TARGET, NONE = "OCCLUDED_REGION", "TARGET", "NONE"


# ------------------------------------------------------------------------------------------- statistics
def decided(views) -> list:
    """The views decided on: (mode, targets remaining, heap height m, unexplored ground m^2) without the
    NONE views (a view of two fields has heap height 0, one of three unexplored ground inf)."""
    return [(view[0], view[1], view[2] if len(view) > 2 else 0.0, view[3] if len(view) > 3 else math.inf)
            for view in views if view[0] != NONE]


def reveal_runs(views, low_height: float = 0.0, impurity_area: float = 0.0) -> list:
    """(L, L_low, explored) of every reveal in one episode's views ((mode, targets remaining, heap height,
    unexplored ground) in order): a run of L OCCLUDED_REGION views in a row ending in a TARGET view with
    targets remaining, the last L_low of them at heaps lower than `low_height` (m) in a row, explored when
    a view of the run had less unexplored ground than `impurity_area` (m^2) (module docstring)."""
    found, run, explored = [], SearchRun(), False
    for mode, remaining, heap, unexplored in decided(views):
        if mode == TARGET and run.pushes and remaining > 0:
            found.append((run.pushes, run.low, explored))
        run.add(mode == OCCLUDED, heap, low_height, unexplored, impurity_area)
        explored = run.pushes > 0 and (explored or run.explored)
    return found


def reveals(views) -> list:
    """The length L of every reveal in one episode's views (reveal_runs)."""
    return [length for length, _, _ in reveal_runs(views)]


def cut_at(views, k: int, k_low: int | None = None, low_height: float = 0.0,
           impurity_area: float = 0.0) -> int | None:
    """The index among the decided views of the one on which search_pushes = k (and low_heap_pushes =
    k_low at heaps lower than `low_height`, and the table memory with `impurity_area`) ends the episode,
    or None when it never does."""
    run = SearchRun()
    for index, (mode, _, heap, unexplored) in enumerate(decided(views)):
        run.add(mode == OCCLUDED, heap, low_height, unexplored, impurity_area)
        if run.over(k, k_low):
            return index
    return None


def replay(row: dict, k: int, k_low: int | None = None, low_height: float = 0.0,
           impurity_area: float = 0.0) -> tuple[int, int]:
    """(impurities left behind, actions saved) had the recorded episode `row` run with search_pushes = k
    (and low_heap_pushes = k_low, and the table memory with `impurity_area`): those in the workspace where
    it would have ended that the unended episode picked, and the actions it took from there on."""
    views = decided(row["views"])
    cut = cut_at(views, k, k_low, low_height, impurity_area)
    if cut is None:
        return 0, 0
    return max(0, views[cut][1] - row["remaining_end"]), max(0, row["actions"] - cut)


def impurities(rows) -> int:
    return sum(row["impurities"] for row in rows)


def search_table(rows, ks, impurity_area: float = 0.0) -> dict:
    """{k: {"left_behind": share of the impurities whose reveal needed more than k pushes, "reveals_left":
    their count, "replayed": share left behind replaying the episodes (replay), "actions_saved": mean
    actions saved per episode}}, the table memory with `impurity_area` (m^2; 0: none). ValueError when the
    episodes hold no impurity."""
    return _table(rows, [(k, None) for k in ks], 0.0, impurity_area, key=0)


def low_heap_table(rows, search_pushes: int, low_height: float, k_lows, impurity_area: float = 0.0) -> dict:
    """search_table's figures per low_heap_pushes k_low in `k_lows`, with search_pushes fixed and low heaps
    lower than `low_height` (m)."""
    return _table(rows, [(search_pushes, k_low) for k_low in k_lows], low_height, impurity_area, key=1)


def _table(rows, pairs, low_height: float, impurity_area: float, key: int) -> dict:
    total = impurities(rows)
    if total <= 0:
        raise ValueError("no impurity in the episodes: run more episodes")
    runs = [run for row in rows for run in reveal_runs(row["views"], low_height, impurity_area)]
    table = {}
    for k, k_low in pairs:
        replayed = [replay(row, k, k_low, low_height, impurity_area) for row in rows]
        left = sum(explored or length > k or (k_low is not None and low > k_low)
                   for length, low, explored in runs)
        table[(k, k_low)[key]] = {"left_behind": left / total, "reveals_left": left,
                    "replayed": sum(lost for lost, _ in replayed) / total,
                    "actions_saved": sum(saved for _, saved in replayed) / max(len(rows), 1)}
    return table


def choose_search_pushes(rows, max_left_behind: float, cap: int = SEARCH_PUSHES_CAP,
                         impurity_area: float = 0.0) -> tuple[int, dict]:
    """(the least search_pushes in 1 ... cap whose share left behind is at most max_left_behind, the table
    for 1 ... cap; the table memory with `impurity_area`). ValueError naming --max-left-behind when none
    is."""
    table = search_table(rows, range(1, cap + 1), impurity_area)
    for k, figures in table.items():
        if figures["left_behind"] <= max_left_behind + 1e-12:
            return k, table
    worst = max(length for row in rows for length in reveals(row["views"]))
    raise ValueError(f"no search_pushes up to {cap} leaves at most {max_left_behind:.1%} of the impurities "
                     f"behind (a reveal needed {worst} pushes): raise --max-left-behind or --cap")


def choose_low_heap_pushes(rows, search_pushes: int, low_height: float, max_left_behind: float,
                           impurity_area: float = 0.0) -> tuple:
    """(the least low_heap_pushes in 1 ... search_pushes whose share left behind, with search_pushes and low
    heaps lower than `low_height`, is at most max_left_behind, the table); search_pushes itself when no
    smaller one is (low heaps then searched as long as any)."""
    table = low_heap_table(rows, search_pushes, low_height, range(1, search_pushes + 1), impurity_area)
    for k_low, figures in table.items():
        if figures["left_behind"] <= max_left_behind + 1e-12:
            return k_low, table
    return search_pushes, table


# ------------------------------------------------------------------------------------------ the episodes
def search_jobs(palettes, seeds: int, scenarios=SEARCH_SCENARIOS) -> list:
    """(scenario, palette, seed) per scenario, seeds SEARCH_SEED_BASE + k for k < seeds, the palettes
    cycled. CalibrationRefused for a palette or seed outside the tuning split."""
    check_palettes(palettes)
    seed_list = [SEARCH_SEED_BASE + k for k in range(seeds)]
    check_seeds(seed_list)
    return [(scenario, palette, seed) for scenario in scenarios
            for palette, seed in zip(itertools.cycle(palettes), seed_list)]


def key_of(row: dict) -> tuple:
    return row["scenario"], row["palette"], row["seed"], row["max_actions"]


def collect_search_episodes(jobs: list, out: pathlib.Path, checkpoint, params, max_actions: int = 0,
                            progress: bool = True, piece_height: float = DEFAULT_PIECE_HEIGHT) -> None:
    """Run the jobs (attention `params`, search_pushes and low_heap_pushes SEARCH_UNENDED, impurity_area 0,
    max_actions 0: the loop's default) and append each episode's decided views to `out` (jobs already there
    are skipped); unexplored ground is measured for pieces of `piece_height` m."""
    from tqdm import tqdm

    from impurity_common.enums import AttentionMode
    from impurity_policy.core import picking
    from impurity_policy.core.episode import EpisodeRequest
    from ur5_driver_sim.core.world import CellWorld

    from ..agents import make_agent
    from ..evaluate import PerceptionSimCell, _reraise

    class RecordingCell(PerceptionSimCell):
        """Records each view decided on: attention's mode, the targets remaining in the workspace, the
        attended heap's height (m) and the unexplored ground (m^2) the loop's table memory measures."""

        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.views, self.memory = [], picking.TableMemory()

        def observe(self):
            view = super().observe()
            self.memory.look(view.height)
            return view

        def decide(self, view):
            unexplored = self.memory.unexplored_area(view.height, picking.hiding_height(piece_height))
            self.views.append([AttentionMode(int(view.mode)).name, int(self.truth().targets_remaining),
                               round(float(view.heap_height), 4), round(unexplored, 6)])
            return super().decide(view)

    out.parent.mkdir(parents=True, exist_ok=True)
    done = {key_of(row) for row in read_episodes([out])} if out.exists() else set()
    world = CellWorld(mode="floating")
    agent = make_agent("ours", pathlib.Path(checkpoint), "cell")
    limits = picking.EpisodeLimits(search_pushes=SEARCH_UNENDED, low_heap_pushes=SEARCH_UNENDED,
                                   impurity_area=0.0, piece_height=piece_height)
    try:
        with out.open("a") as sink:
            for scenario, palette, seed in tqdm(jobs, desc="search episodes", disable=not progress):
                if (scenario, palette, seed, max_actions) in done:
                    continue
                cell = RecordingCell(world, agent, attention_params=params)
                request = EpisodeRequest(scenario, seed=seed, max_actions=max_actions, palette=palette)
                summary = picking.run_episode(cell, request, f"{scenario}-{seed}", limits, on_error=_reraise)
                sink.write(json.dumps({"scenario": scenario, "palette": palette, "seed": seed,
                                       "max_actions": max_actions,
                                       "termination": summary["termination_reason"],
                                       "actions": summary["actions"],
                                       "impurities": summary["truth_targets_total"],
                                       "remaining_end": int(cell.truth().targets_remaining),
                                       "views": cell.views}) + "\n")
                sink.flush()
    finally:
        world.close()
