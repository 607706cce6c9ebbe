"""python -m impurity_learning.calibrate {network,verifier,verdict,episode-end,search-pushes,colour-reference}
    --out DIR

Fits the cell's learned parts and thresholds to a product and camera, on the tuning split only; see the
package docstring and each subcommand's --help. Exit status 0 on success, 2 when the data is refused or
does not allow a fit (the message says why).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

from impurity_policy.core.episode import DEFAULT_IMPURITY_AREA, DEFAULT_PIECE_HEIGHT
from impurity_policy.core.picking import low_heap_height

from . import attention_fit, episodes, scenes, search
from .scenes import CalibrationRefused

COLOUR_REFERENCE_FILE = "colour_reference.json"

TUNING_ONLY = ("Fits on the tuning split only (impurity_learning.splits): the default and tuning palettes\n"
               "(palettes.yaml's split field; random palettes of the tuning seed ranges) on tuning scene\n"
               "seeds 0 ... 99 999. Refuses held-out palettes and evaluation seeds.")


def _write_json(path: pathlib.Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {path}")


def _network_option(value: str | None, out: pathlib.Path):
    """--network: a weights file, "shipped", "none", or by default OUT/impurity_net.pt if there, else the
    shipped network."""
    from impurity_attention.core.impurity_net import read_network

    if value == "none":
        return None
    if value == "shipped":
        return read_network(None)
    if value is not None:
        return read_network(value)
    written = out / attention_fit.NETWORK_FILE
    return read_network(written if written.exists() else None)


def run_network(args) -> int:
    from impurity_attention.core.impurity_net import write_network

    records = scenes.scenes_of(args)
    net, losses, provenance = attention_fit.fit_network(records, args.epochs, args.positive_weight,
                                                        progress=not args.no_progress)
    path = args.out / attention_fit.NETWORK_FILE
    write_network(net, path, provenance)
    print(f"wrote {path}: {provenance}")
    return 0


def run_verifier(args) -> int:
    from impurity_attention.core.verifier import ALL_FEATURES, FEATURES, write_verifier

    network = _network_option(args.network, args.out)
    records = scenes.scenes_of(args)
    rows = attention_fit.verifier_rows(records, network=network, progress=not args.no_progress)
    names = ALL_FEATURES if network is not None else FEATURES
    provenance = (f"python -m impurity_learning.calibrate verifier: {len(rows[4])} tuning scenes, "
                  f"{len(set(rows[3].tolist()))} palettes")
    if args.refit:
        from impurity_attention.core.verifier import read_verifier

        model = read_verifier(None if args.refit_from == "shipped" else args.refit_from)
        provenance = (f"{model.provenance}; then {', '.join(args.refit)} refitted, the other weights held "
                      f"(python -m impurity_learning.calibrate verifier --refit {' '.join(args.refit)}): "
                      f"{len(rows[4])} tuning scenes, {len(set(rows[3].tolist()))} palettes")
        try:
            verifier, figures = attention_fit.extend_verifier(model, *rows, added=tuple(args.refit),
                                                              provenance=provenance)
        except ValueError as error:
            print(f"calibrate verifier: --refit: {error}", file=sys.stderr)
            return 2
    else:
        verifier, figures = attention_fit.fit_verifier(*rows, feature_names=names, provenance=provenance)
    for name in ("before", "out_of_fold", "fitted"):
        if name in figures:
            print(f"{name.replace('_', ' ')}: {100 * figures[name]['found']:.1f} % found, "
                  f"{100 * figures[name]['false_target']:.1f} % false TARGET (threshold at "
                  f"{100 * attention_fit.CAPS['threshold']:.0f} % of the clean scenes)")
    for field, entry in figures["thresholds"].items():
        print(f"{field} = {entry['value']}: lets {entry['clean_through']} of {entry['clean_scenes']} scenes "
              f"without a visible impurity through (at most {100 * entry['cap']:.2f} %)")
    path = args.out / attention_fit.VERIFIER_FILE
    write_verifier(verifier, path)
    print(f"wrote {path}")
    return 0


def run_colour_reference(args) -> int:
    from impurity_attention.core.colour_adaptation import lab_statistics

    records = scenes.scenes_of(args)
    if not records:
        raise ValueError("no scene to measure")
    # a cell no camera ray reached is black in the colour heightmap, not a scene colour: left out
    stats = lab_statistics([r.color for r in records], [r.labels != -1 for r in records])
    mean, std = [round(v, 2) for v in stats.mean], [round(v, 2) for v in stats.std]
    print(f"Lab statistics of {len(records)} rendered tuning scenes: mean {mean}, std {std}")
    lines = ("heightmap:\n  ros__parameters:\n    colour_adaptation: true\n"
             f"    colour_reference_mean: {mean}\n    colour_reference_std: {std}\n")
    print(f"for the heightmap node's parameters (bringup/config/cell.yaml):\n{lines}", end="")
    _write_json(args.out / COLOUR_REFERENCE_FILE,
                {"colour_reference_mean": mean, "colour_reference_std": std, "scenes": len(records)})
    return 0


def _episode_files(args, name: str) -> list:
    return list(args.episodes) if args.episodes else [args.out / name]


def run_verdict(args) -> int:
    if not args.episodes:
        palettes = args.palettes or episodes.default_palettes(args.random_palettes)
        jobs = episodes.verdict_jobs(palettes, args.seeds)
        params = attention_fit.attention_params(args.out)
        episodes.collect_verdict_episodes(jobs, args.out / "verdict_episodes.jsonl", args.checkpoint, params,
                                          progress=not args.no_progress)
    rows = episodes.read_episodes(_episode_files(args, "verdict_episodes.jsonl"))
    episodes.check_episodes(rows)
    chosen = episodes.choose_verdict(rows)
    print(f"{len(rows)} tuning episodes, {chosen['grasps']} grasps: min_color_contrast "
          f"{chosen['min_color_contrast']} (least spread "
          f"{chosen['min_color_spread']:.0f}, shading {chosen['color_shading']:.1f}): agreement "
          f"{100 * chosen['agreement']:.1f} %, count match {100 * chosen['count_match']:.1f} %")
    _write_json(args.out / "verdict.json", {**chosen, "episodes": len(rows)})
    return 0


def run_episode_end(args) -> int:
    if not args.episodes:
        palettes = args.palettes or episodes.default_palettes(args.random_palettes)
        jobs = episodes.episode_end_jobs(args.heights, palettes, args.seeds)
        if args.scene_sets:
            jobs += episodes.scene_set_end_jobs(args.heights, palettes, args.seeds, args.scene_sets)
        params = attention_fit.attention_params(args.out)
        episodes.collect_end_episodes(jobs, args.out / "episode_end_episodes.jsonl", args.checkpoint, params,
                                      progress=not args.no_progress)
    rows = episodes.read_episodes(_episode_files(args, "episode_end_episodes.jsonl"))
    episodes.check_episodes(rows)
    height, table = episodes.choose_height(rows)
    print("min_cluster_height  episodes  clean_end  ended_by_NONE  left_behind  completion  actions")
    for h, f in table.items():
        mark = "  <- chosen" if h == height else ""
        print(f"{h:18.3f}  {f['episodes']:8d}  {f['clean_end']:9.1%}  {f['ended_by_none']:13.1%}  "
              f"{f['left_behind']:11d}  {f['completion']:10.1%}  {f['actions']:7.1f}{mark}")
    _write_json(args.out / "episode_end.json",
                {"min_cluster_height": height, "figures": {f"{h:.3f}": f for h, f in table.items()}})
    return 0


def run_search_pushes(args) -> int:
    if not args.episodes:
        palettes = args.palettes or episodes.default_palettes(args.random_palettes)
        jobs = search.search_jobs(palettes, args.seeds, args.scenarios)
        params = attention_fit.attention_params(args.out)
        search.collect_search_episodes(jobs, args.out / search.EPISODES_FILE, args.checkpoint, params,
                                       args.max_actions, progress=not args.no_progress,
                                       piece_height=args.piece_height)
    rows = episodes.read_episodes(_episode_files(args, search.EPISODES_FILE))
    episodes.check_episodes(rows)
    if not rows:
        raise ValueError("no episodes to choose from")
    lengths = sorted(length for row in rows for length in search.reveals(row["views"]))
    area = args.impurity_area
    table = search.search_table(rows, range(1, args.cap + 1), area)
    total = search.impurities(rows)
    print(f"{len(rows)} tuning episodes, {total} impurities, {len(lengths)} reveals (pushes at heaps before "
          f"a hidden impurity showed: {' '.join(map(str, lengths)) or 'none'}); table memory: impurities "
          f"of {area * 1e4:.1f} cm^2")
    print("search_pushes  left_behind  reveals_left  replayed  actions_saved")
    for k, f in table.items():
        print(f"{k:13d}  {f['left_behind']:11.1%}  {f['reveals_left']:12d}  {f['replayed']:8.1%}  "
              f"{f['actions_saved']:13.2f}")
    chosen, _ = search.choose_search_pushes(rows, args.max_left_behind, args.cap, area)
    print(f"search_pushes {chosen}: the least that leaves at most {args.max_left_behind:.1%} of the "
          f"impurities behind ({table[chosen]['left_behind']:.1%})")
    low_height = low_heap_height(args.piece_height)
    low, low_table = search.choose_low_heap_pushes(rows, chosen, low_height, args.max_left_behind, area)
    print(f"low heaps (lower than {low_height * 1000:.0f} mm), search_pushes {chosen}:")
    print("low_heap_pushes  left_behind  reveals_left  replayed  actions_saved")
    for k, f in low_table.items():
        print(f"{k:15d}  {f['left_behind']:11.1%}  {f['reveals_left']:12d}  {f['replayed']:8.1%}  "
              f"{f['actions_saved']:13.2f}")
    print(f"low_heap_pushes {low}: the least that keeps it within {args.max_left_behind:.1%} "
          f"({low_table[low]['left_behind']:.1%})")
    _write_json(args.out / search.RESULT_FILE,
                {"search_pushes": chosen, "low_heap_pushes": low, "piece_height": args.piece_height,
                 "impurity_area": area,
                 "max_left_behind": args.max_left_behind, "reveals": lengths,
                 "impurities": total, "episodes": len(rows), "seeds": sorted({r["seed"] for r in rows}),
                 "palettes": sorted({r["palette"] for r in rows}),
                 "figures": {str(k): f for k, f in table.items()}})
    return 0


def _episode_options(parser, seeds: int, what: str) -> None:
    from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT

    parser.add_argument("--palettes", nargs="+", default=None, metavar="NAME",
                        help="default and tuning palettes, cycled over the episodes (default: the default "
                             "palette, the named tuning palettes and --random-palettes random ones)")
    parser.add_argument("--random-palettes", type=int, default=4, help="random tuning palettes (default 4)")
    parser.add_argument("--seeds", type=int, default=seeds, help=f"episodes per {what} (default {seeds})")
    parser.add_argument("--checkpoint", default=str(SHIPPED_CHECKPOINT), help="the policy network")
    parser.add_argument("--episodes", type=pathlib.Path, nargs="+", default=None, metavar="JSONL",
                        help="choose from these recorded episode files instead of running episodes")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def parse_args(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m impurity_learning.calibrate",
        description="Fit the cell to a product and camera, on the tuning split only. Run the subcommands "
                    "in this order with the same --out: network, verifier, verdict, episode-end, "
                    "search-pushes (and, for a "
                    "real camera with colour adaptation, colour-reference); each reads what the earlier ones "
                    "wrote there.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="SUBCOMMAND")
    fmt = argparse.RawDescriptionHelpFormatter

    def add(name, summary, description):
        p = sub.add_parser(name, help=summary, description=f"{summary}\n\n{description}\n\n{TUNING_ONLY}",
                           formatter_class=fmt)
        p.add_argument("--out", type=pathlib.Path, required=True, help="the calibration directory")
        return p

    p = add("network", "fit the impurity network (per-cell impurity probability)",
            "Trains impurity_attention's impurity network on rendered tuning scenes (or --views), the\n"
            "simulator's truth the label, the exposure drawn in 0.5 ... 2.\n"
            "Writes OUT/impurity_net.pt (read by verifier, verdict, episode-end; the cell reads it as\n"
            "impurity_attention/checkpoints/impurity_net.pt).")
    scenes.add_options(p)
    p.add_argument("--epochs", type=int, default=attention_fit.NETWORK_EPOCHS,
                   help=f"training epochs (default {attention_fit.NETWORK_EPOCHS})")
    p.add_argument("--positive-weight", type=float, default=None,
                   help="an impurity cell's weight in the loss (default "
                        "impurity_net_training.POSITIVE_WEIGHT)")
    p.set_defaults(run=run_network)

    p = add("verifier", "fit the region verifier and the thresholds attention reads from it",
            "Logistic regression over the features attention computes for the best salient regions of\n"
            "rendered tuning scenes (or --views), with the impurity network's features when a network is\n"
            "given, and the three thresholds on its best-region probability per scene: each the least\n"
            "probability letting through at most a fixed share of the scenes without a visible impurity:\n"
            f"threshold {100 * attention_fit.CAPS['threshold']:.0f} %, last_look "
            f"{100 * attention_fit.CAPS['last_look']:.2f} %, stall_look "
            f"{100 * attention_fit.CAPS['stall_look']:.2f} %\n"
            "(the shares the shipped values let through under the shipped verifier on its tuning scenes).\n"
            "They are chosen here, not by a command of their own, because they read this model's\n"
            "probabilities: a refitted model needs all three anew, and one file holds what attention reads.\n"
            "Prints palette-grouped cross-validation (with 5 palettes or more).\n"
            "Writes OUT/verifier.json in the shipped format (impurity_attention.core.verifier's\n"
            "write_verifier: feature names, weights and bias over the standardised features, threshold,\n"
            "last_look, stall_look); the cell reads it as impurity_attention/checkpoints/verifier.json.")
    scenes.add_options(p)
    p.add_argument("--refit", nargs="+", default=None, metavar="FEATURE",
                   help="refit only these features' weights (and the intercept) of the --refit-from model, "
                        "its other weights held; a feature it does not read is added "
                        "(attention_fit.extend_verifier)")
    p.add_argument("--refit-from", default="shipped", metavar="JSON",
                   help="the model --refit starts from: a verifier.json or 'shipped' (default)")
    p.add_argument("--network", default=None,
                   help="the impurity network: a weights file, 'shipped' or 'none' (default: "
                        "OUT/impurity_net.pt if there, else the shipped one)")
    p.set_defaults(run=run_verifier)

    p = add("verdict", "choose the grasp verdict's colour test (was an impurity picked?)",
            "Runs fast-sim episodes counted as a real cell counts (attention as calibrated in OUT) without\n"
            "the verdict's colour test, then chooses min_color_contrast and the product reference's least\n"
            "spread and shading by the agreement of the verdict with the simulator's truth.\n"
            "Writes OUT/verdict_episodes.jsonl (resumable) and OUT/verdict.json.")
    _episode_options(p, 12, "scenario and scene size")
    p.set_defaults(run=run_verdict)

    p = add("episode-end", "choose the height below which a dense cluster hides nothing",
            "Runs fast-sim episodes counted as a real cell counts (attention as calibrated in OUT) for each\n"
            "min_cluster_height, and chooses the one whose episodes most often end by attention's NONE with\n"
            "no impurity left (ties: the lowest), on the scenes every height ran.\n"
            "Writes OUT/episode_end_episodes.jsonl (resumable) and OUT/episode_end.json.")
    _episode_options(p, 8, "scene size")
    p.add_argument("--heights", type=float, nargs="+", default=list(episodes.HEIGHTS),
                   help="min_cluster_height values tried, m (default "
                        f"{' '.join(f'{h:g}' for h in episodes.HEIGHTS)})")
    p.add_argument("--scene-sets", nargs="+", default=[], metavar="SET",
                   help="also --seeds scenes per layout of each of these scene sets (ur5_driver_sim.core."
                        "scenes.SCENE_SETS, e.g. tall flat sparse dense clean; SET@LOW-HIGH: piece heights "
                        "in mm) on their tuning seeds")
    p.set_defaults(run=run_episode_end)

    p = add("search-pushes", "choose how many pushes at heaps without an impurity end the search",
            "Runs fast-sim episodes counted as a real cell counts (attention as calibrated in OUT) on the\n"
            "random, challenging and invisible scenes with the search never ended, recording per view\n"
            "attention's mode, the simulator's truth and the ground not yet seen down to the table. A\n"
            "hidden impurity that showed after L pushes in a row at heaps with none in view is left behind\n"
            "by search_pushes < L, or by the table memory (--impurity-area). Prints, per\n"
            "search_pushes, the share of the impurities left behind (and replayed: the episodes cut where\n"
            "they would have ended) and the actions saved per episode, and chooses the least search_pushes\n"
            "leaving at most --max-left-behind behind (episode.search_pushes in bringup/config/cell.yaml).\n"
            f"Writes OUT/{search.EPISODES_FILE} (resumable) and OUT/{search.RESULT_FILE}.")
    _episode_options(p, 12, "scenario")
    p.add_argument("--max-left-behind", type=float, default=0.02,
                   help="the share of the impurities the end of the search may leave behind (default 0.02)")
    p.add_argument("--scenarios", nargs="+", default=list(search.SEARCH_SCENARIOS),
                   choices=search.SEARCH_SCENARIOS, help="scenarios run (default all three)")
    p.add_argument("--max-actions", type=int, default=0,
                   help="actions per episode (default 0: the loop's max_actions_uncounted)")
    p.add_argument("--piece-height", type=float, default=DEFAULT_PIECE_HEIGHT,
                   help="one piece of your product (m): heaps lower than twice this are low heaps, and "
                        "only material higher than one piece covers an impurity "
                        f"(episode.piece_height; default {DEFAULT_PIECE_HEIGHT})")
    p.add_argument("--impurity-area", type=float, default=DEFAULT_IMPURITY_AREA,
                   help="the footprint of your smallest impurity (m^2): the table memory's "
                        f"(episode.impurity_area; default {DEFAULT_IMPURITY_AREA}; 0: no table memory)")
    p.add_argument("--cap", type=int, default=search.SEARCH_PUSHES_CAP,
                   help=f"the largest search_pushes chosen (default {search.SEARCH_PUSHES_CAP})")
    p.set_defaults(run=run_search_pushes)

    p = add("colour-reference", "measure the simulator's colour statistics for colour adaptation",
            "Renders tuning scenes (or reads --views) and measures the mean and standard deviation of their\n"
            "colour heightmaps in OpenCV float CIE Lab (L 0 ... 100, a and b about -127 ... 127; cells no\n"
            "camera ray reached left out): the units of the heightmap node's colour_reference_mean and\n"
            "colour_reference_std, the reference a real camera's colours are moved to when its\n"
            "colour_adaptation is true. Prints the yaml lines to paste.\n"
            f"Writes OUT/{COLOUR_REFERENCE_FILE} (colour_reference_mean, colour_reference_std).")
    scenes.add_options(p)
    p.set_defaults(run=run_colour_reference)
    return parser.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        return args.run(args)
    except (CalibrationRefused, ValueError) as error:
        print(f"calibrate {args.command}: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
