"""The end of the search (impurity_policy.core.picking, EpisodeLimits.search_pushes, low_heap_pushes,
piece_height, impurity_area): counted by perception, after `search_pushes` pushes in a row at heaps that
showed no impurity (`low_heap_pushes` at heaps lower than two pieces), the next such view ends the episode as
"nothing left"; a target in view starts the count over. The table memory ends it sooner: once the ground the
episode never saw down to the table, under material thicker than one piece, is smaller than one impurity,
nothing can hide. Counted by truth it never applies (the paper's protocol ends on the count). Specified
against a scripted cell."""

import numpy as np
import pytest

from impurity_policy.core.episode import TERMINATION_ACTION_LIMIT, TERMINATION_NOTHING_LEFT, EpisodeRequest
from impurity_policy.core.picking import Action, EpisodeLimits, Outcome, TableMemory, View, run_episode
from impurity_policy.core.policy import MODE_OCCLUDED_REGION, MODE_TARGET

OCCLUDED, TARGET = MODE_OCCLUDED_REGION, MODE_TARGET
TALL, LOW = 0.1, 0.05  # m: heap heights either side of two 35 mm pieces


class ScriptedCell:
    """Attention answers `modes` in turn, then OCCLUDED_REGION for ever, each heap `heights` in turn (then
    TALL); every decision pushes. counts: reset's target count (None: the loop counts by perception)."""

    def __init__(self, modes=(), counts=None, heights=()):
        self.modes, self.counts, self.heights, self.pushes = list(modes), counts, list(heights), 0

    def reset(self, request):
        return self.counts

    def observe(self):
        mode = self.modes.pop(0) if self.modes else OCCLUDED
        height = (self.heights.pop(0) if self.heights else TALL) if mode == OCCLUDED else 0.0
        return View(mode, heap_height=height)

    def decide(self, view):
        return Action("push", (0.5, 0.0, 0.02), 0.0, 1.0, 0, (100, 100), view.mode)

    def execute(self, action):
        self.pushes += 1
        return Outcome(True, False, "push")

    def targets_remaining(self, outcome, before):
        return before


def run(cell, **limits):
    request = EpisodeRequest("invisible", seed=1, num_targets=2, max_actions=30)
    return run_episode(cell, request, "ep-1", EpisodeLimits(**limits))


@pytest.mark.parametrize("pushes", [1, 3, 5])
def test_a_clean_bin_ends_after_search_pushes_pushes_at_heaps(pushes):
    cell = ScriptedCell()
    summary = run(cell, search_pushes=pushes)
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT
    assert summary["actions"] == cell.pushes == pushes
    assert summary["completed"]


def test_a_target_in_view_starts_the_count_over():
    # two pushes, a target (pushed at here), two more pushes: four at heaps but never three in a row
    cell = ScriptedCell(modes=[OCCLUDED, OCCLUDED, TARGET, OCCLUDED, OCCLUDED])
    summary = run(cell, search_pushes=2)
    assert summary["actions"] == 5  # the sixth view is the third at a heap in a row
    assert summary["termination_reason"] == TERMINATION_NOTHING_LEFT


def test_counted_by_truth_the_search_never_ends_the_episode():
    cell = ScriptedCell(counts=2)
    summary = run(cell, search_pushes=2)
    assert summary["termination_reason"] == TERMINATION_ACTION_LIMIT and summary["actions"] == 30


def test_more_search_pushes_cost_more_actions_on_a_clean_bin():
    actions = [run(ScriptedCell(), search_pushes=k)["actions"] for k in (2, 4, 8)]
    assert actions == [2, 4, 8]


def test_low_heaps_end_the_search_after_low_heap_pushes():
    summary = run(ScriptedCell(heights=[LOW] * 30), search_pushes=5, low_heap_pushes=2)
    assert summary["actions"] == 2 and summary["termination_reason"] == TERMINATION_NOTHING_LEFT


def test_a_tall_heap_breaks_the_run_of_low_ones_but_not_the_search():
    # low, low, tall, low, low: never three low in a row; the sixth push in a row ends it
    summary = run(ScriptedCell(heights=[LOW, LOW, TALL, LOW, LOW, TALL]), search_pushes=5, low_heap_pushes=2)
    assert summary["actions"] == 5


@pytest.mark.parametrize("piece,actions", [(0.035, 2), (0.02, 5)])
def test_a_heap_is_low_below_two_pieces_of_the_products_height(piece, actions):
    # a 50 mm heap: low for 35 mm pieces (below 70 mm), not for 20 mm ones (above 40 mm)
    summary = run(ScriptedCell(heights=[LOW] * 30), search_pushes=5, low_heap_pushes=2, piece_height=piece)
    assert summary["actions"] == actions


@pytest.mark.parametrize("field", ["search_pushes", "low_heap_pushes"])
@pytest.mark.parametrize("pushes", [0, -2])
def test_a_count_below_one_is_refused_naming_the_field(field, pushes):
    with pytest.raises(ValueError, match=field):
        EpisodeLimits(**{field: pushes})


# ----------------------------------------------------------------------- on heightmaps, through attention
def heap_view(layers: int, piece: float = 0.05):
    """Attention's view of a product-only heightmap: a 6 x 6 grid of `piece`-tall blocks (45 mm pitch, one
    colour) with `layers` of them in the middle four (a stack), as the episode node receives it."""
    from impurity_attention.core.attention import attend

    color = np.full((224, 224, 3), 60, np.uint8)
    height = np.zeros((224, 224), np.float32)
    for row in range(6):
        for col in range(6):
            r, c = 50 + row * 22, 50 + col * 22
            stacked = 2 <= row <= 3 and 2 <= col <= 3
            height[r:r + 18, c:c + 18] = piece * (layers if stacked else 1)
            color[r:r + 18, c:c + 18] = (150, 120, 90)
    output = attend(color, height)
    assert output.mode == OCCLUDED  # product only: a heap, no target
    return View(int(output.mode), heap_height=float(output.score))


@pytest.mark.parametrize("layers,actions", [(1, 2), (3, 5)])
def test_one_layer_of_pieces_is_a_low_heap_and_a_stack_is_searched_longer(layers, actions):
    # 50 mm pieces: one layer stands lower than two pieces (a low heap), a stack of three does not
    view = heap_view(layers)
    assert (view.heap_height < 0.1) == (layers == 1)

    class Cell(ScriptedCell):
        def observe(self):
            return view

    summary = run(Cell(), search_pushes=5, low_heap_pushes=2, piece_height=0.05)
    assert summary["actions"] == actions and summary["termination_reason"] == TERMINATION_NOTHING_LEFT


# ------------------------------------------------------------------------------------------ the table memory
CELL_AREA = 0.448 * 0.448 / (224 * 224)  # m^2: one cell of the 224 x 224 map of the workspace (2 mm)
HEAP_A, HEAP_B = (slice(40, 80), slice(40, 80)), (slice(140, 180), slice(140, 180))  # 40 x 40 cells each


def height_map(*heaps, height=0.08):
    """A 224 x 224 height map (m): the table, and `height` on each heap's cells."""
    surface = np.zeros((224, 224), np.float32)
    for heap in heaps:
        surface[heap] = height
    return surface


class HeapCell(ScriptedCell):
    """Attention attends a heap on every view; the height maps are `maps` in turn (then the last for ever)."""

    def __init__(self, maps):
        super().__init__()
        self.maps = list(maps)

    def observe(self):
        surface = self.maps.pop(0) if len(self.maps) > 1 else self.maps[0]
        return View(OCCLUDED, height=surface, heap_height=float(np.nanmax(surface)))


def test_the_memory_measures_ground_never_seen_down_to_the_table_under_thick_material():
    memory = TableMemory()
    memory.look(height_map(HEAP_A))
    assert memory.unexplored_area(height_map(HEAP_A), 0.043) == pytest.approx(1600 * CELL_AREA)
    assert memory.unexplored_area(height_map(HEAP_B), 0.043) == 0.0  # B stood on ground seen as table
    assert memory.unexplored_area(height_map(HEAP_A, height=0.04), 0.043) == 0.0  # too thin to cover


def test_a_heap_pushed_onto_ground_seen_down_to_the_table_ends_the_search():
    # the push moves the heap from A (never seen below) to B, seen as table in the first view
    cell = HeapCell([height_map(HEAP_A), height_map(HEAP_B)])
    summary = run(cell, search_pushes=5)
    assert summary["actions"] == 1 and summary["termination_reason"] == TERMINATION_NOTHING_LEFT


def test_a_heap_standing_where_the_table_was_never_seen_is_searched_for_search_pushes():
    summary = run(HeapCell([height_map(HEAP_A)]), search_pushes=5, low_heap_pushes=5)
    assert summary["actions"] == 5


@pytest.mark.parametrize("impurity_area,actions", [(0.0005, 1), (0.0001, 5)])
def test_unexplored_ground_smaller_than_one_impurity_hides_nothing(impurity_area, actions):
    # the heap moves to B, of which a 5 x 5 cell corner (1 cm^2) lies on ground A covered in the first view
    moved = (slice(75, 115), slice(75, 115))
    cell = HeapCell([height_map(HEAP_A), height_map(moved)])
    assert 25 * CELL_AREA == pytest.approx(0.0001)
    summary = run(cell, search_pushes=5, low_heap_pushes=5, impurity_area=impurity_area * 0.99)
    assert summary["actions"] == actions


@pytest.mark.parametrize("piece_height,actions", [(0.035, 1), (0.02, 5)])
def test_only_material_thicker_than_one_piece_can_cover_an_impurity(piece_height, actions):
    # one layer 30 mm tall on ground never seen: nothing under it for 35 mm pieces (one push, then the
    # search ends), a second layer for 20 mm ones
    cell = HeapCell([height_map(HEAP_A, height=0.03)])
    summary = run(cell, search_pushes=5, low_heap_pushes=5, piece_height=piece_height)
    assert summary["actions"] == actions


def test_the_memory_ends_the_search_only_after_a_push_at_a_heap():
    # a target in view, then a heap on ground seen down to the table: a push moved the impurity, maybe
    # under it, so the heap is pushed once before the memory may end the search
    class Cell(HeapCell):
        def observe(self):
            view = super().observe()
            return View(TARGET, height=view.height) if self.pushes == 1 else view

    summary = run(Cell([height_map(HEAP_A), height_map(HEAP_A), height_map(HEAP_B)]), search_pushes=5)
    assert summary["actions"] == 3  # the heap at A, the target, the heap at B; then B is explored


def test_ground_of_unknown_height_is_never_taken_for_explored():
    unknown = height_map(HEAP_A)
    unknown[HEAP_A] = np.nan  # colour without depth over the heap
    summary = run(HeapCell([unknown]), search_pushes=5, low_heap_pushes=5)
    assert summary["actions"] == 5


def test_counted_by_truth_the_memory_never_ends_the_episode():
    cell = HeapCell([height_map(HEAP_A), height_map(HEAP_B)])
    cell.counts = 2
    summary = run(cell, search_pushes=2)
    assert summary["termination_reason"] == TERMINATION_ACTION_LIMIT and summary["actions"] == 30
