"""The generalisation table: how the cell does on appearances it was not tuned on.

For each scenario x palette group ("default", "tuning", "held_out" and "lightness", held-out palettes whose
impurities differ from the product mainly in lightness, of splits.py):
- perception, measured on rendered scenes with the attention module alone (no policy): detection of
  visible targets (the TARGET mask lies on an impurity) and false TARGET on scenes without impurities;
- picking, from evaluation episodes (eval_cli): grasp success, action efficiency and completion per
  method and rules preset.
A group's episodes cycle through its palettes (episode k of a group uses palette k mod n) on the
evaluation seeds; nothing here is ever used to choose a parameter.

Writes docs/generalisation.md (table), docs/images/generalisation.png (chart) and
docs/images/generalisation_scenes.png (one scene per group, camera image and attention overlay).
"""

from __future__ import annotations

import math
import os
import pathlib

import numpy as np

from . import splits

GROUPS = ("default", "tuning", "held_out", "lightness")
DEFAULT_GROUPS = ("default", "tuning", "held_out")  # eval_cli's --palette-groups unless told
GROUP_LABELS = {"default": "default (blocks)", "tuning": "tuning palettes", "held_out": "held-out palettes",
                "lightness": "held-out lightness palettes"}
RANDOM_PALETTES_PER_GROUP = 4  # random palettes beside the named ones in the tuning group (held-out: all)


def group_palettes(group: str) -> list:
    """The palettes episodes and scenes of a group cycle through."""
    if group == "default":
        return [splits.DEFAULT_PALETTE]
    if group == "tuning":
        return list(splits.TUNING_NAMED) + [f"random-{s}" for s in
                                            splits.TUNING_RANDOM_SEEDS[:RANDOM_PALETTES_PER_GROUP]]
    if group == "held_out":  # the whole held-out set (splits.held_out_palettes)
        return splits.held_out_palettes()
    if group == "lightness":  # impurities differing mainly in lightness (splits.held_out_lightness_palettes)
        return splits.held_out_lightness_palettes()
    raise ValueError(f"unknown palette group {group!r} (expected one of {', '.join(GROUPS)})")


def palette_for(group: str, k: int) -> str:
    palettes = group_palettes(group)
    return palettes[k % len(palettes)]


def perception(world, groups, scenarios, scenes: int, seed_base: int, progress=None) -> dict:
    """{group: {scenario: {"found", "visible_scenes", "false_target", "clean_scenes"}}} from `scenes`
    rendered scenes with impurities and `scenes` without, per group and scenario (evaluation seeds)."""
    from impurity_attention.core import evaluation
    from impurity_attention.core.attention import attend

    results = {}
    for group in groups:
        results[group] = {}
        for scenario in scenarios:
            found, visible, false, clean = 0, 0, 0, 0
            for k in range(scenes):
                palette = palette_for(group, k)
                for targets in (-1, 0):
                    try:
                        record = evaluation.record_from_world(world, scenario, seed_base + k, targets, -1,
                                                              palette=palette)
                    except (RuntimeError, ValueError):  # the sim could not build it: not counted
                        continue
                    verdict = evaluation.judge(record, attend(record.color, record.height))
                    if verdict.category == "visible":
                        visible += 1
                        found += verdict.success
                    elif verdict.category == "no_impurity":
                        clean += 1
                        false += not verdict.success
                    if progress is not None:
                        progress()
            results[group][scenario] = {
                "found": 100.0 * found / visible if visible else math.nan, "visible_scenes": visible,
                "false_target": 100.0 * false / clean if clean else math.nan, "clean_scenes": clean}
    return results


def _percent(value) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{value:.1f}"


def table(results: dict, rows, scenarios, groups, label) -> str:
    """Markdown: perception per group and scenario, then per metric a row per method and a column per
    group x scenario."""
    gen = results["_generalisation"]
    lines = ["**Perception (attention alone): visible impurity found / false TARGET on scenes without "
             "impurity, %**", "", "| Palette group | " + " | ".join(scenarios) + " |",
             "|---|" + "---|" * len(scenarios)]
    for group in groups:
        cells = []
        for scenario in scenarios:
            entry = gen["perception"][group][scenario]
            cells.append(f"{_percent(entry['found'])} / {_percent(entry['false_target'])} "
                         f"(n = {entry['visible_scenes']} / {entry['clean_scenes']})")
        lines.append(f"| {GROUP_LABELS[group]} | " + " | ".join(cells) + " |")
    sections = ["\n".join(lines)]
    columns = [(g, s) for g in groups for s in scenarios]
    for title, key in (("Grasp success, %", "grasp_success"), ("Action efficiency, %", "action_efficiency"),
                       ("Completion, %", "completion")):
        lines = [f"**{title}** (columns: palette group / scenario)", "",
                 "| Method | " + " | ".join(f"{g} / {s}" for g, s in columns) + " |",
                 "|---|" + "---|" * len(columns)]
        for row in rows:
            entry = results[row]
            if entry.get("missing"):
                continue
            cells = [_percent(entry["groups"].get(g, {}).get(s, {}).get(key)) for g, s in columns]
            lines.append(f"| {label(row)} | " + " | ".join(cells) + " |")
        sections.append("\n".join(lines))
    return "\n\n".join(sections)


def plot(results: dict, rows, scenarios, groups, label, path: pathlib.Path) -> None:
    """Grasp success and completion per method, one panel per scenario, bars per palette group."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = [r for r in rows if not results[r].get("missing")]
    fig, axes = plt.subplots(2, len(scenarios), figsize=(4.6 * len(scenarios), 7.2), squeeze=False)
    width = 0.8 / max(len(groups), 1)
    x = np.arange(len(shown))
    for column, scenario in enumerate(scenarios):
        for line, (key, title) in enumerate((("grasp_success", "grasp success %"),
                                             ("completion", "completion %"))):
            axis = axes[line][column]
            for i, group in enumerate(groups):
                values = [results[r]["groups"].get(group, {}).get(scenario, {}).get(key, math.nan)
                          for r in shown]
                axis.bar(x + (i - (len(groups) - 1) / 2) * width, values, width, label=GROUP_LABELS[group])
            axis.set_xticks(x, [label(r) for r in shown], rotation=60, ha="right", fontsize=7)
            axis.set_ylim(0, 105)
            axis.set_title(f"{scenario}: {title}", fontsize=9)
            axis.grid(axis="y", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Generalisation across appearances (evaluation seeds; palettes cycle within a group)",
                 fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def scene_pictures(world, groups, seed: int, path: pathlib.Path) -> None:
    """One random scene per group (its first palette): camera image beside the attention overlay."""
    import cv2

    from impurity_attention.core import evaluation
    from impurity_attention.core.attention import attend, debug_image

    rows = []
    for group in groups:
        palette = palette_for(group, 1 if group != "default" else 0)
        record, frame = evaluation.record_from_world(world, "random", seed, -1, -1, keep_frame=True,
                                                     palette=palette)
        output = attend(record.color, record.height)
        camera = cv2.resize(frame.color, (298, 224), interpolation=cv2.INTER_AREA)[:, 37:261]
        pair = np.concatenate([camera, debug_image(record.color, output)], axis=1).copy()
        cv2.putText(pair, f"{GROUP_LABELS[group]}: {palette}", (4, 218), cv2.FONT_HERSHEY_SIMPLEX, 0.42,
                    (255, 255, 255), 1, cv2.LINE_AA)
        rows.append(pair)
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), cv2.cvtColor(np.concatenate(rows, axis=1), cv2.COLOR_RGB2BGR))


def write_markdown(results, rows, scenarios, groups, label, path: pathlib.Path, chart: pathlib.Path,
                   pictures: pathlib.Path, command: str) -> None:
    gen = results["_generalisation"]
    palettes = {g: ", ".join(group_palettes(g)) for g in groups}
    lines = ["# Generalisation across appearances (fast sim)", "",
             f"Generated by `{command}` on {results['_meta']['date']}. Palette groups (splits.py): "
             + "; ".join(f"**{g}**: {palettes[g]}" for g in groups) + ". "
             f"Episodes per method, group and scenario: default {gen['episodes']['default']}, others "
             f"{gen['episodes']['other']} (episode k uses the group's palette k mod n, seed "
             f"{results['_meta']['seed_base']} + k). Perception: {gen['scenes']} scenes with and "
             f"{gen['scenes']} without impurities per group and scenario. Held-out palettes and these seeds "
             "were never used to choose anything.", "",
             f"Time: perception {gen['seconds']['perception']:.0f} s, episodes "
             f"{results['_meta']['seconds']:.0f} s (both groups of episodes together).", "",
             table(results, rows, scenarios, groups, label), "",
             f"![generalisation]({os.path.relpath(chart, path.parent)})", "",
             f"![scenes]({os.path.relpath(pictures, path.parent)})", ""]
    path.write_text("\n".join(lines) + "\n")
