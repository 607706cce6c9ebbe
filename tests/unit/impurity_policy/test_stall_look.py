"""The picking loop's stall look (impurity_policy.core.picking, EpisodeLimits.stall_look_views): after pushes
at heaps that showed no impurity, attention looks again at a lower threshold, and the loop decides on that
look. Specified against a scripted cell, counted by truth and by perception; attend's side (closer=True) is
specified in tests/unit/impurity_attention/test_stall_look_attention.py."""

import pytest

from impurity_policy.core.episode import TERMINATION_ACTION_LIMIT, EpisodeRequest
from impurity_policy.core.picking import Action, EpisodeLimits, Outcome, View, run_episode
from impurity_policy.core.policy import MODE_NONE, MODE_OCCLUDED_REGION, MODE_TARGET

OCCLUDED, TARGET, NONE = MODE_OCCLUDED_REGION, MODE_TARGET, MODE_NONE
TALL_HEAP = 0.1  # m: a heap taller than two pieces (EpisodeLimits.piece_height)


class StallingCell:
    """Attention answers `modes` in turn (then OCCLUDED_REGION); every decision pushes (a push moves
    nothing that matters here). look_closer() answers `closer` in turn (then OCCLUDED_REGION), and every
    call is logged with the number of views looked at before it. counts: reset's target count (None: the
    loop counts by perception)."""

    def __init__(self, modes=(), closer=(), counts=2):
        self.modes, self.closer, self.counts = list(modes), list(closer), counts
        self.views, self.looks, self.decided = 0, [], []

    def reset(self, request):
        return self.counts

    def observe(self):
        self.views += 1
        return View(self.modes.pop(0) if self.modes else OCCLUDED, heap_height=TALL_HEAP)

    def look_closer(self):
        self.looks.append(self.views)
        return View(self.closer.pop(0) if self.closer else OCCLUDED, source="closer", heap_height=TALL_HEAP)

    def decide(self, view):
        self.decided.append((view.mode, view.source))
        return Action("push", (0.5, 0.0, 0.02), 0.0, 1.0, 0, (100, 100), view.mode)

    def execute(self, action):
        return Outcome(True, False, "push")

    def targets_remaining(self, outcome, before):
        return before


def run(cell, actions=12, **limits):
    request = EpisodeRequest("challenging", seed=1, num_targets=2, max_actions=actions)
    return run_episode(cell, request, "ep-1", EpisodeLimits(**limits))


@pytest.mark.parametrize("counts", [2, None], ids=["by truth", "by perception"])
def test_the_fifth_occluded_view_in_a_row_is_looked_at_closer_and_the_count_starts_over(counts):
    cell = StallingCell(counts=counts)
    summary = run(cell, actions=12, search_pushes=100)  # the search does not end it (test_search_end.py)
    assert summary["termination_reason"] == TERMINATION_ACTION_LIMIT
    assert cell.looks == [5, 10]  # the 5th and the 10th view; 12 views in all
    assert [source for _, source in cell.decided].count("closer") == 2


@pytest.mark.parametrize("counts", [2, None], ids=["by truth", "by perception"])
def test_the_loop_decides_on_the_closer_look(counts):
    cell = StallingCell(closer=[TARGET], counts=counts)
    run(cell, actions=6)
    assert cell.decided[4] == (TARGET, "closer")
    assert [mode for mode, _ in cell.decided] == [OCCLUDED] * 4 + [TARGET, OCCLUDED]


def test_a_view_that_is_not_occluded_breaks_the_row():
    cell = StallingCell(modes=[OCCLUDED] * 4 + [TARGET] + [OCCLUDED] * 5)
    run(cell, actions=10)
    assert cell.looks == [10]  # views 1-4, then a target, then 6-10: the fifth in a row is view 10


def test_none_views_break_the_row_when_counting_by_perception():
    # three NONE views would end the episode: two, then attention sees a heap again
    cell = StallingCell(modes=[OCCLUDED] * 4 + [NONE, NONE] + [OCCLUDED] * 5, counts=None)
    run(cell, actions=9, none_frames_to_finish=3, search_pushes=100)
    assert cell.looks == [11]


def test_a_cell_that_cannot_look_closer_is_decided_on_as_before():
    class Plain(StallingCell):
        look_closer = None

    cell = Plain()
    summary = run(cell, actions=7)
    assert summary["actions"] == 7 and all(source is None for _, source in cell.decided)


def test_a_cell_answering_none_keeps_the_view_it_had():
    class Unable(StallingCell):
        def look_closer(self):
            self.looks.append(self.views)
            return None

    cell = Unable()
    run(cell, actions=6)
    assert cell.looks == [5] and cell.decided[4] == (OCCLUDED, None)


@pytest.mark.parametrize("views", [0, -1])
def test_a_count_below_one_is_refused_naming_the_field(views):
    with pytest.raises(ValueError, match="stall_look_views"):
        EpisodeLimits(stall_look_views=views)
