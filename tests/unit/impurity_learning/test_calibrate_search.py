"""python -m impurity_learning.calibrate search-pushes: the end of the search (EpisodeLimits.search_pushes)
measured on episodes counted by perception. A hidden impurity that showed after L pushes in a row at heaps
with none in view (a reveal) is left behind by search_pushes < L; the tool chooses the least search_pushes
leaving at most --max-left-behind of the impurities behind. Synthetic view sequences, and one short
episode in the simulator."""

import json

import pytest

from impurity_learning import splits
from impurity_learning.calibrate import CalibrationRefused, search
from impurity_learning.calibrate.__main__ import main

H, T, N = search.OCCLUDED, search.TARGET, search.NONE  # a push at a heap, a target, nothing


def views(modes, remaining=1):
    """(mode, targets remaining) per view; `remaining` one count for all or one per view."""
    counts = remaining if isinstance(remaining, list) else [remaining] * len(modes)
    return list(zip(modes, counts, strict=True))


def episode(modes, remaining=1, impurities=1, remaining_end=0, seed=70_000, palette="blocks"):
    return {"scenario": "invisible", "palette": palette, "seed": seed, "max_actions": 0,
            "termination": "no_target_or_cluster_left", "actions": sum(m != N for m in modes),
            "impurities": impurities, "remaining_end": remaining_end,
            "views": [list(v) for v in views(modes, remaining)]}


# ------------------------------------------------------------------------------------------ the reveals
def test_pushes_at_heaps_ending_in_a_target_are_a_reveal_of_their_length():
    assert search.reveals(views([H, H, H, T, H, T])) == [3, 1]


def test_a_target_without_pushes_before_it_is_no_reveal():
    assert search.reveals(views([T, T, H, T])) == [1]


def test_a_run_at_the_episodes_end_is_no_reveal():
    assert search.reveals(views([H, T, H, H, H])) == [1]


def test_a_run_ending_in_none_views_at_the_end_is_no_reveal():
    assert search.reveals(views([H, H, N, N, N])) == []


def test_a_none_view_is_not_decided_on_and_does_not_break_the_run():
    # picking counts the views it decides on: a NONE between two pushes leaves the count going
    assert search.reveals(views([H, H, N, H, T])) == [3]


def test_a_run_after_the_last_impurity_is_no_reveal():
    # the last impurity was picked (remaining 0): a TARGET after pushes is product taken for one
    assert search.reveals(views([H, T, H, H, T], remaining=[1, 1, 0, 0, 0])) == [1]


def test_search_pushes_k_ends_the_episode_on_the_k_plus_first_push_in_a_row():
    seq = views([H, T, H, H, N, H, T])
    assert search.cut_at(seq, 3) is None
    assert search.cut_at(seq, 2) == 4  # the fifth view decided on (the NONE is not one)
    assert search.cut_at(seq, 1) == 3


# ------------------------------------------------------------------------------------ share and choice
ROWS = [episode([H, H, H, T], impurities=1),  # a reveal of 3
        episode([H, T, H, H, H, H, H, T], remaining=[2, 2, 1, 1, 1, 1, 1, 1], impurities=2),  # 1 and 5
        episode([T, H, H], remaining=[1, 0, 0], impurities=1)]  # shown at once, then pushes at a clean bin


def test_the_share_left_behind_is_the_reveals_longer_than_k_over_the_impurities():
    table = search.search_table(ROWS, range(1, 7))
    assert [table[k]["reveals_left"] for k in range(1, 7)] == [2, 2, 1, 1, 0, 0]
    assert table[2]["left_behind"] == pytest.approx(2 / 4)
    assert table[5]["left_behind"] == 0


def test_replaying_counts_what_ending_the_episode_there_leaves_and_saves():
    # search_pushes 1 ends the second episode on its fourth view, its second impurity still hidden
    assert search.replay(ROWS[1], 1) == (1, 5)
    assert search.replay(ROWS[2], 1) == (0, 1)
    assert search.replay(ROWS[0], 3) == (0, 0)


def test_the_least_search_pushes_within_the_accepted_share_is_chosen():
    assert search.choose_search_pushes(ROWS, 0.0)[0] == 5
    assert search.choose_search_pushes(ROWS, 0.25)[0] == 3
    assert search.choose_search_pushes(ROWS, 0.5)[0] == 1


def test_no_search_pushes_up_to_the_cap_within_the_share_is_refused_naming_the_option():
    with pytest.raises(ValueError, match="--max-left-behind"):
        search.choose_search_pushes(ROWS, 0.0, cap=4)


def test_episodes_without_an_impurity_are_refused():
    with pytest.raises(ValueError, match="no impurity"):
        search.search_table([episode([H, H], impurities=0)], [1])


# ------------------------------------------------------------------------------------------- the split
def test_the_jobs_are_tuning_seeds_on_the_given_palettes_per_scenario():
    jobs = search.search_jobs(["blocks", "coal_slate"], seeds=3)
    assert len(jobs) == 3 * len(search.SEARCH_SCENARIOS)
    assert all(seed in splits.TUNING_SEED_RANGE for *_, seed in jobs)
    assert [palette for _, palette, _ in jobs[:3]] == ["blocks", "coal_slate", "blocks"]


def test_a_held_out_palette_is_refused():
    with pytest.raises(CalibrationRefused, match="held_out"):
        search.search_jobs(["blocks", "durum_wheat_stones"], seeds=1)


def test_evaluation_seeds_are_refused(monkeypatch):
    monkeypatch.setattr(search, "SEARCH_SEED_BASE", splits.EVAL_SEED_BASE)
    with pytest.raises(CalibrationRefused, match="evaluation"):
        search.search_jobs(["blocks"], seeds=1)


# ------------------------------------------------------------------------------------------- low heaps
LOW, TALL = 0.05, 0.09  # m: heap heights either side of 2 x 35 mm


def heaps(spec, remaining=1):
    """Views from a string: 'l' a push at a low heap, 'h' at a tall one, 't' a target."""
    kinds = {"l": (H, LOW), "h": (H, TALL), "t": (T, 0.0)}
    counts = remaining if isinstance(remaining, list) else [remaining] * len(spec)
    return [[kinds[c][0], n, kinds[c][1]] for c, n in zip(spec, counts, strict=True)]


def explored(spec, remaining=1, area=0.0005):
    """heaps(spec) with unexplored ground per view: 'e' a push at a heap with none left (explored)."""
    views = heaps(spec.replace("e", "h"), remaining)
    return [[*view, 0.0 if c == "e" else 1.0] for view, c in zip(views, spec, strict=True)]


def test_a_reveal_after_a_view_with_too_little_unexplored_ground_is_left_behind_by_the_table_memory():
    assert search.reveal_runs(explored("hhht"), impurity_area=0.0005) == [(3, 0, False)]
    assert search.reveal_runs(explored("hhet"), impurity_area=0.0005) == [(3, 0, True)]
    assert search.reveal_runs(explored("hetht"), impurity_area=0.0005) == [(2, 0, True), (1, 0, False)]
    # the first view of a run is given its push: the memory ends the search from the second on
    assert search.reveal_runs(explored("ehtet"), impurity_area=0.0005) == [(2, 0, False), (1, 0, False)]
    assert search.reveal_runs(explored("hhet")) == [(3, 0, False)]  # no impurity area: no memory


def test_the_table_memory_ends_a_replay_on_the_first_explored_view_and_counts_what_it_leaves():
    row = episode([H, H, H, H, H, T])
    row["views"] = explored("hhehht")  # the impurity showed after 5 pushes, one of them at explored ground
    assert search.cut_at(row["views"], 10, impurity_area=0.0005) == 2
    assert search.replay(row, 10, impurity_area=0.0005) == (1, row["actions"] - 2)
    table = search.search_table([row], [10], impurity_area=0.0005)
    assert table[10]["left_behind"] == 1.0 and search.search_table([row], [10])[10]["left_behind"] == 0.0


def test_a_reveal_counts_its_last_pushes_at_low_heaps_in_a_row():
    assert search.reveal_runs(heaps("hhllt"), low_height=0.07) == [(4, 2, False)]
    assert search.reveal_runs(heaps("llhlt"), low_height=0.07) == [(4, 1, False)]  # a tall heap breaks it
    assert search.reveal_runs(heaps("hhllt")) == [(4, 0, False)]  # no low height: nothing is low


def test_low_heap_pushes_ends_the_search_at_low_heaps_first():
    views = heaps("hhlllt")
    assert search.cut_at(views, 5) is None
    assert search.cut_at(views, 5, k_low=2, low_height=0.07) == 4  # the third low heap in a row
    assert search.cut_at(views, 5, k_low=3, low_height=0.07) is None


LOW_ROWS = [{"scenario": "invisible", "palette": "blocks", "seed": 70_000, "max_actions": 0, "actions": a,
             "impurities": 1, "remaining_end": 0, "views": v}
            for a, v in [(3, heaps("hht")), (4, heaps("hlht")), (5, heaps("lllt")),
                         (6, heaps("tlllll", remaining=[1, 0, 0, 0, 0, 0]))]]


def test_the_least_low_heap_pushes_within_the_share_is_chosen_with_search_pushes_fixed():
    assert search.choose_low_heap_pushes(LOW_ROWS, 5, 0.07, 0.0)[0] == 3  # the reveal after 3 low heaps
    k_low, table = search.choose_low_heap_pushes(LOW_ROWS, 5, 0.07, 0.25)
    assert k_low == 1 and table[1]["reveals_left"] == 1  # 1 of 4 left behind, within 25 %
    assert table[1]["actions_saved"] > table[3]["actions_saved"]  # the clean bin ends sooner


def test_with_no_low_height_low_heap_pushes_changes_nothing():
    k_low, table = search.choose_low_heap_pushes(LOW_ROWS, 5, 0.0, 0.0)
    assert k_low == 1 and table[1] == search.search_table(LOW_ROWS, [5])[5]


# ------------------------------------------------------------------------------------------- the tool
def write(path, rows):
    path.write_text("\n".join(json.dumps(r) for r in rows) + "\n")
    return path


def test_the_subcommand_writes_the_chosen_search_pushes_and_its_reveals(tmp_path, capsys):
    path = write(tmp_path / "search.jsonl", ROWS)
    out = tmp_path / "calibration"
    assert main(["search-pushes", "--out", str(out), "--episodes", str(path),
                 "--max-left-behind", "0.25"]) == 0
    chosen = json.loads((out / "search_pushes.json").read_text())
    assert chosen["search_pushes"] == 3 and chosen["max_left_behind"] == 0.25
    # views without heap heights are all low: low_heap_pushes is search_pushes
    assert chosen["low_heap_pushes"] == 3 and chosen["piece_height"] == pytest.approx(0.035)
    assert chosen["reveals"] == [1, 3, 5] and chosen["impurities"] == 4 and chosen["episodes"] == 3
    assert chosen["seeds"] == [70_000] and chosen["palettes"] == ["blocks"]
    assert "search_pushes 3" in capsys.readouterr().out


def test_the_subcommand_exits_2_when_no_search_pushes_is_within_the_share(tmp_path, capsys):
    path = write(tmp_path / "search.jsonl", ROWS)
    assert main(["search-pushes", "--out", str(tmp_path), "--episodes", str(path), "--max-left-behind", "0",
                 "--cap", "4"]) == 2
    assert "raise --max-left-behind" in capsys.readouterr().err
    assert not (tmp_path / "search_pushes.json").exists()


def test_the_subcommand_refuses_episodes_of_an_evaluation_seed(tmp_path, capsys):
    path = write(tmp_path / "search.jsonl", [episode([H, T], seed=splits.EVAL_SEED_BASE + 1)])
    assert main(["search-pushes", "--out", str(tmp_path), "--episodes", str(path)]) == 2
    assert "evaluation" in capsys.readouterr().err


def test_a_short_simulated_episode_records_each_decided_view_with_the_truth(tmp_path):
    pytest.importorskip("pybullet")
    from impurity_learning.calibrate import attention_fit
    from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT

    out = tmp_path / "search.jsonl"
    jobs = search.search_jobs(["blocks"], seeds=1, scenarios=("invisible",))
    search.collect_search_episodes(jobs, out, SHIPPED_CHECKPOINT, attention_fit.attention_params(None),
                                   max_actions=3, progress=False)
    search.collect_search_episodes(jobs, out, SHIPPED_CHECKPOINT, attention_fit.attention_params(None),
                                   max_actions=3, progress=False)  # resumed: nothing run twice
    (row,) = [json.loads(line) for line in out.read_text().splitlines()]
    assert row["seed"] == search.SEARCH_SEED_BASE and row["impurities"] >= 1
    assert 1 <= len(row["views"]) <= 3 and row["actions"] <= 3
    modes = [(mode, remaining) for mode, remaining, _, _ in row["views"]]
    assert all(mode in (H, T) and 0 <= remaining <= row["impurities"] for mode, remaining in modes)
    assert all((heap > 0) == (mode == H) for mode, _, heap, _ in row["views"])  # the attended heap's height
    # the invisible layout's closed boxes stand where the first view never saw the table
    assert row["views"][0][3] > 0.0005
