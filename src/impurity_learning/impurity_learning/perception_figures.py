"""make eval's figures for episodes counted by perception (evaluate.run_episode(by_perception=True)), as a
real cell counts: attention's NONE ends the episode, and the simulator's truth is only recorded beside.

Per row and scenario, over episodes (each a run_episode summary with its truth audit): impurities picked
and left behind by truth, product pieces lifted (grasps that lifted something but no target, by truth),
actions, action efficiency by truth (picked / actions, %), grasp success by truth (grasps that removed an
impurity / grasps, %; 0 in an episode without a grasp, as the truth count's episode.EpisodeTracker
counts it), each as a mean with a 95 % t interval over
episodes, and how the episodes ended: the cell's own "nothing left", the action limit, or otherwise
(repeated failures, an error). Scenes without any impurity (clean scenes) give actions and product lifted.

    figures = perception_figures(episodes)
    figures["actions"]  # {"mean": 7.5, "low": 3.1, "high": 11.9}
"""

from __future__ import annotations

import math

import numpy as np

from impurity_policy.core.episode import TERMINATION_ACTION_LIMIT, TERMINATION_NOTHING_LEFT

ENDINGS = ("nothing_left", "action_limit", "other")  # how an episode ended, as the tables count it


def mean_interval(values) -> dict:
    """Mean of `values` and its 95 % t interval (Student's t, n - 1 degrees of freedom, sample standard
    deviation): {"mean", "low", "high"}; low and high are NaN with fewer than two values, all three NaN
    with none."""
    values = np.asarray(list(values), dtype=float)
    if values.size == 0:
        return {"mean": math.nan, "low": math.nan, "high": math.nan}
    mean = float(values.mean())
    if values.size < 2:
        return {"mean": mean, "low": math.nan, "high": math.nan}
    from scipy.stats import t

    half = float(t.ppf(0.975, values.size - 1) * values.std(ddof=1) / math.sqrt(values.size))
    return {"mean": mean, "low": mean - half, "high": mean + half}


def ending(termination_reason: str) -> str:
    """One of ENDINGS for an episode's termination reason."""
    if termination_reason == TERMINATION_NOTHING_LEFT:
        return "nothing_left"
    if termination_reason == TERMINATION_ACTION_LIMIT:
        return "action_limit"
    return "other"


def product_lifted(steps) -> int:
    """Grasps (episode.StepRecord) that lifted something (success) while the truth says no target went:
    product pieces lifted out of the scene."""
    return sum(s.kind == "grasp" and s.success and s.truth_target_grasped is False for s in steps)


def perception_figures(episodes: list) -> dict:
    """Figures of episodes counted by perception on scenes with impurities: episodes, picked, left,
    product_lifted, actions, efficiency (% by truth) as mean_interval dicts per scene, grasp_success (% by
    truth, per episode, as the truth count's), picked_total and
    targets_total (by truth) and ended ({ENDINGS: episodes})."""
    picked = [e["truth_targets_picked"] for e in episodes]
    return {"episodes": len(episodes), "picked": mean_interval(picked),
            "left": mean_interval(e["truth_targets_total"] - e["truth_targets_picked"] for e in episodes),
            "product_lifted": mean_interval(e["truth_product_lifted"] for e in episodes),
            "actions": mean_interval(e["actions"] for e in episodes),
            "efficiency": mean_interval(100.0 * e["truth_targets_picked"] / e["actions"] if e["actions"]
                                        else 0.0 for e in episodes),
            "grasp_success": mean_interval(100.0 * e["truth_targets_picked"] / e["grasp_attempts"]
                                           if e["grasp_attempts"] else 0.0 for e in episodes),
            "picked_total": int(sum(picked)),
            "targets_total": int(sum(e["truth_targets_total"] for e in episodes)),
            "ended": endings(episodes)}


def clean_figures(episodes: list) -> dict:
    """Figures of episodes counted by perception on clean scenes (no impurity): episodes, actions and
    product_lifted (mean_interval dicts per scene) and ended ({ENDINGS: episodes})."""
    return {"episodes": len(episodes), "actions": mean_interval(e["actions"] for e in episodes),
            "product_lifted": mean_interval(e["truth_product_lifted"] for e in episodes),
            "ended": endings(episodes)}


def by_scenario(episodes: list, scenarios) -> dict:
    """One row's episodes counted by perception (records with scenario and clean_scene) -> {"scenarios":
    {scenario: perception_figures}, "clean_scenes": {scenario: clean_figures}, "episodes": episodes}."""
    def of(scenario, clean):
        return [e for e in episodes if e["scenario"] == scenario and e["clean_scene"] == clean]

    return {"scenarios": {s: perception_figures(of(s, False)) for s in scenarios},
            "clean_scenes": {s: clean_figures(of(s, True)) for s in scenarios}, "episodes": episodes}


def endings(episodes: list) -> dict:
    counts = dict.fromkeys(ENDINGS, 0)
    for e in episodes:
        counts[ending(e["termination_reason"])] += 1
    return counts


def shown(figure: dict, digits: int = 1) -> str:
    """"2.5 [1.2, 3.8]": a mean_interval dict in a table cell ("–" for NaN parts)."""
    def number(value):
        return "–" if not math.isfinite(value) else f"{value:.{digits}f}"

    if not math.isfinite(figure["mean"]):
        return "–"
    return f"{number(figure['mean'])} [{number(figure['low'])}, {number(figure['high'])}]"


def ended(counts: dict) -> str:
    return " / ".join(str(counts[k]) for k in ENDINGS)


def counted_groups(entry: dict) -> list:
    """[(group, by_scenario figures)] of one row's results: the default palette's ("by_perception") first,
    then each other palette group's ("by_perception_groups")."""
    groups = [("default", entry.get("by_perception"))] + list(entry.get("by_perception_groups", {}).items())
    return [(group, counted) for group, counted in groups if counted]


def perception_section(results: dict, rows, scenarios, label, group_labels=None) -> str:
    """Markdown section of the figures in results[row]["by_perception"] ("scenarios", "clean_scenes") and
    results[row]["by_perception_groups"][group] (other palette groups): a table of scenes with impurities
    and, when any ran, one of clean scenes; label(row) names a row, group_labels[group] a palette group
    (default: its name) after the row's label, the default palette's rows without it."""
    lines = ["## Counted by perception", "",
             "The same episodes (rows, scenarios, seeds) counted as a real cell counts: no target count "
             "reaches the loop, attention's NONE ends the episode, grasps are judged by perception. Picked, "
             "left, product lifted and grasp success are the simulator's truth recorded beside the verdicts. "
             "Figures are means per scene with a 95 % t interval over episodes in brackets (Student's t, "
             "n - 1 degrees of freedom; – with fewer than two); ended: episodes ended by the cell's own "
             "\"nothing left\" / at the action limit / otherwise (repeated failures).", "",
             "| Method | Scenario | Episodes | Impurities picked | Left behind | Product lifted | Actions | "
             "Action efficiency, % | Grasp success, % | Ended: nothing left / limit / other |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    clean = []
    for row in rows:
        if results[row].get("missing"):
            continue
        for group, counted in counted_groups(results[row]):
            name = label(row) if group == "default" else \
                f"{label(row)} · {(group_labels or {}).get(group, group)}"
            for scenario in scenarios:
                f = counted["scenarios"].get(scenario)
                if f and f["episodes"]:
                    lines.append(f"| {name} | {scenario} | {f['episodes']} | {shown(f['picked'], 2)} | "
                                 f"{shown(f['left'], 2)} | {shown(f['product_lifted'], 2)} | "
                                 f"{shown(f['actions'])} | {shown(f['efficiency'])} | "
                                 f"{shown(f['grasp_success'])} | {ended(f['ended'])} |")
                c = counted["clean_scenes"].get(scenario)
                if c and c["episodes"]:
                    clean.append(f"| {name} | {scenario} | {c['episodes']} | {shown(c['actions'])} | "
                                 f"{shown(c['product_lifted'], 2)} | {ended(c['ended'])} |")
    if clean:
        lines += ["", "**Clean scenes (no impurity), counted by perception**", "",
                  "| Method | Scenario | Scenes | Actions | Product lifted | "
                  "Ended: nothing left / limit / other |",
                  "|---|---|---|---|---|---|", *clean]
    return "\n".join(lines)
