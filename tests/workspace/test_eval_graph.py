"""impurity_bringup.eval_graph finds the fast sim's records of the seeds it runs in make eval's results file:
the row of the network and rules the graph runs (ours@cell), default palette only."""

import json

from impurity_bringup.eval_graph import FAST_SIM_ROW, fast_sim_records


def episode(row, scenario, seed, group="default", picked=2):
    method, _, rules = row.partition("@")
    return {"method": method, "rules": rules, "row": row, "scenario": scenario, "seed": seed, "group": group,
            "targets_picked": picked}


def test_the_graph_is_compared_with_the_fast_sims_row_of_its_rules_on_the_default_palette(tmp_path):
    results = {FAST_SIM_ROW: {"episodes": [episode(FAST_SIM_ROW, "random", 7),
                                           episode(FAST_SIM_ROW, "random", 7, group="held_out", picked=0)]},
               "ours@none": {"episodes": [episode("ours@none", "challenging", 7)]},
               "_meta": {"episodes": 1}}
    path = tmp_path / "results.json"
    path.write_text(json.dumps(results))
    records = fast_sim_records(path)
    assert list(records) == [("random", 7)] and records[("random", 7)]["targets_picked"] == 2
    assert fast_sim_records(tmp_path / "missing.json") == {}

