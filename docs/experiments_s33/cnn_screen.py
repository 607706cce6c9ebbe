"""Thirty-third session, tuning data only, a third screening (nothing is adopted on it): does a small fully
convolutional network, which sees whole objects and their faces rather than one region's colours, add to the
region verifier on fresh palettes?

The network (CellNet, since the thirty-fourth session impurity_attention's ImpurityNet: 4 input planes, three
resolutions, 0.16 M weights) maps a view's heightmaps, averaged over 2 x 2 cells (4 mm), to a per-cell
impurity logit (read back at full size, bilinear). Its input is relative to the scene, so that no palette
or exposure sets it: CIE L*a*b* of each cell minus the median over the view's object cells, divided by that
channel's median absolute deviation there (floor 2 units), and the height (m x 20); cells without an object
are 0. It is trained on the verifier's fitting first views only (rule-sweep's scenes, the default palette's
also at x0.5 and x2, and the tuning palettes' own-layout scenes: 205 palettes, none of those read below),
labels the visible impurity cells, loss binary cross-entropy over object cells (impurity cells weighted
POSITIVE_WEIGHT), flips and quarter turns at random, EPOCHS epochs of Adam, CPU, seeded.

Read on:
- the 260 fresh tuning palettes of excluded_screen.py: the verifier's rows with two more features per scored
  region, cnn_mean (mean probability over the region's cells) and cnn_high (its 90th percentile), compared by
  the same palette-grouped cross-validation: A, the shipped fifteen; H, the fifteen and the two;
- the check set of check_palettes.py (random-400 ... 599, own layouts): A and H fitted on all 260, threshold
  at 1 % of their clean scenes, read on the check set's rows (found, false TARGET);
- the default palette's exposure set (tuning seeds 30000+) as excluded_screen reads it.

    python docs/experiments_s33/cnn_screen.py [--epochs 8]     # trains the network (runs/s33/cnn.pt)
    python docs/experiments_s33/cnn_screen.py [--jobs 2]       # then the reading
    python docs/experiments_s33/cnn_screen.py --variant H2 --epochs 12; then again with --variant H2
    python docs/experiments_s33/cnn_screen.py --variant H3 --epochs 6; then --variant H3 [--with-default-fit]
    python docs/experiments_s33/cnn_screen.py --variant H4 --epochs 6; then --variant H4 [--with-default-fit]
    python docs/experiments_s33/cnn_screen.py --variant H5 --epochs 6; then --variant H5 [--with-default-fit]
    python docs/experiments_s33/cnn_screen.py --variant H6 --epochs 6; then --variant H6 [--with-default-fit]
The network is saved in runs/s33/cnn.pt, the rows in runs/s33/cnn_rows.npz.
"""
import argparse
import pathlib
import sys

import numpy as np
import torch
from torch import nn
from tqdm import tqdm

sys.path[:0] = ["scripts", "docs/experiments_s11", "docs/experiments_s12", "docs/experiments_s13",
                "docs/experiments_s33"]
import calibrate_attention as ca  # noqa: E402
import check_palettes  # noqa: E402
import excluded_screen as ex  # noqa: E402
import exposure_wide  # noqa: E402
import fresh_layouts  # noqa: E402
import more_palettes  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import sanitize  # noqa: E402
from impurity_attention.core.impurity_net import ImpurityNet as CellNet  # noqa: E402
from impurity_attention.core.impurity_net import pooled as half  # noqa: E402
from impurity_attention.core.impurity_net import scene_planes as scene_input  # noqa: E402
from impurity_attention.core.verifier import FEATURES  # noqa: E402
from impurity_learning import splits  # noqa: E402

NET = pathlib.Path("runs/s33/cnn.pt")
ROWS = pathlib.Path("runs/s33/cnn_rows.npz")
POSITIVE_WEIGHT = 5.0
CNN = ("cnn_mean", "cnn_high")
ALL = FEATURES + CNN
MODELS = {"A shipped fifteen": FEATURES, "H fifteen + network": FEATURES + CNN}
PARTS = ex.PARTS


def objects_of(record) -> tuple:
    color, height = sanitize(record.color, record.height)
    return color, height, height > ex.PARAMS.density.occupied_height


def exposed_input(color, height, objects, factor: float) -> np.ndarray:
    """half(scene_input) of the view with its RGB scaled by `factor` (clipped at 255, a saturating camera)."""
    return half(scene_input(evaluation.exposed_color(color, factor), height, objects))


def training_palette_records() -> list:
    """H3's further training views: random-800 ... 999 (tuning palettes, drawn in earlier picking tests, never
    in a perception fit or reading) on layouts of their own (calibrate_attention.network_palette_records)."""
    return ca.network_palette_records()


WIDE_JITTER = (0.03, 0.06)  # H6: each training palette's product jitter drawn in this range


def wide_palette_records() -> list:
    """H6's further training views: random-800 ... 999 with product jitter drawn uniformly in WIDE_JITTER per
    palette (seeded; the `@j` suffix, ur5_driver_sim's Palette.with_product_jitter), on H3's layouts and seeds
    (calibrate_attention.network_palette_records), cached in palettes_train800_wide_own.npz."""
    rng = np.random.default_rng(6)
    palettes = [f"{name}@j{rng.uniform(*WIDE_JITTER):.3f}" for name in ca.NETWORK_PALETTES]
    return ca.network_palette_records(palettes, "palettes_train800_wide_own.npz")


def default_training_records() -> list:
    """H4's further training views of the default palette (calibrate_attention.network_default_records)."""
    return ca.network_default_records()


def train(epochs: int, exposure: bool = False, more: bool = False, default: bool = False,
          invisible: bool = True, wide: bool = False) -> CellNet:
    """exposure: each training view's exposure drawn log-uniformly in splits.TRAINING_EXPOSURE (H2, H3, H4).
    more: training_palette_records() join the fitting first views (H3, H4). default: so do
    default_training_records() (H4)."""
    torch.manual_seed(0)
    rng = np.random.default_rng(0)
    records, _ = ca.rule_sweep_records()
    records = records + ca.collect_palettes("tuning", own_layouts=True)
    if more:
        records = records + (wide_palette_records() if wide else training_palette_records())
    if default:
        records = records + default_training_records()
    records = [r for r in records if r.category() in evaluation.CATEGORIES]
    if not invisible:  # H5: no invisible-layout scene (their impurities are always cubes)
        records = [r for r in records if r.scenario != "invisible"]
    inputs, labels, masks, views = [], [], [], []
    for record in tqdm(records, desc="inputs"):
        color, height, objects = objects_of(record)
        if exposure:
            views.append((color, height, objects))
            inputs.append(np.zeros((4, *(n // 2 for n in objects.shape)), np.float32))
        else:
            inputs.append(half(scene_input(color, height, objects)))
        labels.append(half((record.visible_target_cells & objects).astype(np.float32)[None])[0])
        masks.append(half(objects.astype(np.float32)[None])[0])
    inputs, labels, masks = (torch.from_numpy(np.stack(a)) for a in (inputs, labels, masks))
    pad = [(-s) % 4 for s in inputs.shape[-2:]]
    net = CellNet()
    optimiser = torch.optim.Adam(net.parameters(), lr=2e-3)
    batch = 16
    for epoch in range(epochs):
        order = rng.permutation(len(inputs))
        total = 0.0
        bar = tqdm(range(0, len(order), batch), desc=f"epoch {epoch + 1}/{epochs}")
        for start in bar:
            index = torch.from_numpy(order[start:start + batch])
            x, y, m = inputs[index], labels[index][:, None], masks[index][:, None]
            if exposure:
                low, high = np.log(splits.TRAINING_EXPOSURE)
                x = torch.from_numpy(np.stack([exposed_input(*views[i], float(np.exp(rng.uniform(low, high))))
                                               for i in order[start:start + batch]]))
            turns = int(rng.integers(4))
            x, y, m = (torch.rot90(t, turns, (2, 3)) for t in (x, y, m))
            if rng.random() < 0.5:
                x, y, m = (torch.flip(t, (3,)) for t in (x, y, m))
            x, y, m = (nn.functional.pad(t, (0, pad[1], 0, pad[0])) for t in (x, y, m))
            logits = net(x)
            weight = m * (1.0 + (POSITIVE_WEIGHT - 1.0) * y)
            loss = nn.functional.binary_cross_entropy_with_logits(logits, y, weight=weight, reduction="sum")
            loss = loss / weight.sum().clamp(min=1.0)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total += float(loss)
            bar.set_postfix(loss=f"{total / (start // batch + 1):.4f}")
        print(f"epoch {epoch + 1}: mean loss {total / len(range(0, len(order), batch)):.4f}", flush=True)
    NET.parent.mkdir(parents=True, exist_ok=True)
    torch.save(net.state_dict(), NET)
    return net


NETWORK: CellNet | None = None


def probability_map(color, height, objects) -> np.ndarray:
    torch.set_num_threads(1)  # in a worker of excluded_screen.table's pool
    return NETWORK.probability(color, height, objects)


def rows_of(index: int) -> list:
    """[(features (len(ALL),), on target)] of excluded_screen.RECORDS[index]'s scored regions."""
    view = ex.scored_view(ex.RECORDS[index])
    probability = probability_map(view.color, view.height, view.objects)
    out = []
    for _, region, row, on in view.candidates:
        values = probability[region.mask]
        out.append((np.concatenate([row, [values.mean(), np.quantile(values, 0.9)]]), on))
    return out


def with_default_fit(sets: dict, jobs: int, transform=lambda parts: parts, models: dict | None = None,
                     cache: pathlib.Path | None = None, guard: bool = False) -> None:
    """The reading with the default palette's fitting exposure scenes (calibrate_attention's
    EXPOSURE_FIT_SEED_BASE, 35000+, at x0.5 / x1 / x2; the network never saw them) among every verifier fit's
    rows: cross-validation folds of the 260 fresh palettes each train with all of them, and the threshold is
    taken at 1 % of the clean scenes of everything fitted on; found and false TARGET are counted on the 260
    palettes' held-out folds, the check set and the exposure check set (30000+) as before. transform: applied
    to the default palette's rows (table()'s parts) as to `sets` (the thirty-fourth session's log-odds).
    models: {name: features} (default MODELS); cache: the default palette's rows (default beside ROWS).
    guard: the threshold is also at least the one at 1 % of the default palette's fitted clean scenes alone
    (the thirty-fourth session's H4LD)."""
    from sklearn.model_selection import GroupKFold
    models = models or MODELS
    cache = cache or ROWS.with_name(ROWS.stem + "_default_fit.npz")
    if cache.exists():
        data = np.load(cache)
        extra = [tuple(data[f"x{e:g}_{k}"] for k in PARTS) for e in ca.EXPOSURES]
    else:
        default = ca.collect_exposure_scenes(ca.EXPOSURE_FIT_SEED_BASE)
        extra = list(ex.exposed_tables(default, jobs, rows_of).values())
        np.savez_compressed(cache, **{f"x{e:g}_{k}": v for e, parts in zip(ca.EXPOSURES, extra, strict=True)
                                      for k, v in zip(PARTS, parts, strict=True)})
    extra = [transform(parts) for parts in extra]

    def joined(parts_list):  # table()'s arrays of several sets as one, scene indices offset
        out, offset = [[] for _ in PARTS], 0
        for f, o, sc, g, v in parts_list:
            for i, a in enumerate((f, o, sc + offset, g, v)):
                out[i].append(a)
            offset += len(v)
        return tuple(np.concatenate(a) for a in out)

    fresh = sets["fresh"]
    fit_all = joined([fresh, *extra])
    count = len(fresh[4])
    print(f"with the default palette's fitting scenes (seeds {ca.EXPOSURE_FIT_SEED_BASE}+, x0.5 / x1 / x2: "
          f"{sum(len(x[4]) for x in extra)} scenes) in every fit")
    for name, chosen in models.items():
        columns = [ALL.index(c) for c in chosen]
        features, on, scene, group, visible = fresh
        x = features[:, columns]
        found = false = 0
        for train, test in GroupKFold(n_splits=5).split(x, on, group):
            kept = np.isin(scene, np.unique(scene[train]))
            part = joined([(features[kept], on[kept], scene[kept], group[kept], visible), *extra])
            fitted = ex.fit(part[0][:, columns], part[1])
            own, _ = ca.scene_decisions(ex.predict(fitted, part[0][:, columns]), part[1], part[2],
                                        len(part[4]))
            seen = np.zeros(len(part[4]), bool)
            seen[part[2]] = True
            least = ca.threshold_at(own[seen], part[4][seen], 0.01)
            if guard:  # the default palette's scenes follow the fresh palettes' in `part`
                tail = np.arange(len(part[4])) >= count
                least = max(least, ca.threshold_at(own[tail], part[4][tail], 0.01))
            best, hit = ca.scene_decisions(ex.predict(fitted, x[test]), on[test], scene[test], count)
            unseen = np.zeros(count, bool)
            unseen[scene[test]] = True
            found += int(np.sum((best >= least) & unseen & hit & visible))
            false += int(np.sum((best >= least) & unseen & ~visible))
        line = (f"{name:22s} cross-validated found {found}/{int(visible.sum())} "
                f"({100 * found / visible.sum():.2f} %), false TARGET {false}/{int((~visible).sum())} "
                f"({100 * false / (~visible).sum():.2f} %)")
        fitted = ex.fit(fit_all[0][:, columns], fit_all[1])
        best, _ = ca.scene_decisions(ex.predict(fitted, fit_all[0][:, columns]), fit_all[1], fit_all[2],
                                     len(fit_all[4]))
        least = ca.threshold_at(best, fit_all[4], 0.01)
        if guard:
            tail = np.arange(len(fit_all[4])) >= count
            least = max(least, ca.threshold_at(best[tail], fit_all[4][tail], 0.01))
        reads = []
        for label, (f, o, sc, _, v) in [("check set", sets["check"])] + [
                (f"x{e:g}", sets[f"x{e:g}"]) for e in ca.EXPOSURES]:
            b, h = ca.scene_decisions(ex.predict(fitted, f[:, columns]), o, sc, len(v))
            taken = b >= least
            reads.append(f"{label} found {int(np.sum(taken & h & v))}/{int(v.sum())}, false "
                         f"{int(np.sum(taken & ~v))}/{int((~v).sum())}")
        print(f"{line}\n    fitted on all (threshold {least:.3f}): " + "; ".join(reads), flush=True)


def main() -> None:
    global NETWORK
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--epochs", type=int, default=8)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--with-default-fit", action="store_true",
                        help="the reading with the default palette's fitting exposure scenes in every fit")
    parser.add_argument("--variant", choices=("H", "H2", "H3", "H4", "H5", "H6"), default="H",
                        help="H2: exposure drawn at random in training (runs/s33/cnn_h2.pt, cnn_h2_rows.npz)")
    args = parser.parse_args()
    global NET, ROWS, MODELS
    if args.variant in ("H2", "H3", "H4", "H5", "H6"):
        tag = args.variant.lower()
        NET, ROWS = NET.with_name(f"cnn_{tag}.pt"), ROWS.with_name(f"cnn_{tag}_rows.npz")
        MODELS = {"A shipped fifteen": FEATURES, f"{args.variant} fifteen + network": FEATURES + CNN}
    if not NET.exists():  # training in a process of its own: torch's thread pool does not survive a fork
        torch.set_num_threads(2)
        later = ("H4", "H5", "H6")
        train(args.epochs, exposure=args.variant in ("H2", "H3", *later), more=args.variant in ("H3", *later),
              default=args.variant in later, invisible=args.variant != "H5", wide=args.variant == "H6")
        print(f"trained {NET}; run again for the reading")
        return
    NETWORK = CellNet()
    NETWORK.load_state_dict(torch.load(NET))
    NETWORK.eval()
    if ROWS.exists():
        data = np.load(ROWS)
        sets = {name: tuple(data[f"{name}_{k}"] for k in PARTS)
                for name in ("fresh", "check", "x0.5", "x1", "x2")}
    else:
        fresh = more_palettes.extra_records(200) + fresh_layouts.own_layout_records(700, 60)
        sets = {"fresh": ex.table(fresh, args.jobs, rows_of),
                "check": ex.table(check_palettes.check_records(), args.jobs, rows_of)}
        for e, parts in ex.exposed_tables(exposure_wide.collect(), args.jobs, rows_of).items():
            sets[f"x{e:g}"] = parts
        np.savez_compressed(ROWS, **{f"{name}_{k}": v for name, parts in sets.items()
                                     for k, v in zip(PARTS, parts, strict=True)})
    if args.with_default_fit:
        with_default_fit(sets, args.jobs)
        return
    plain_reading(sets)


def plain_reading(sets: dict, models: dict | None = None) -> None:
    """The reading without the default palette in the fits: cross-validation on the fresh palettes, the
    exposure check set, and the check set read by models fitted on all the fresh palettes. models: {name:
    features} (default MODELS)."""
    models = models or MODELS
    ex.compare(sets["fresh"], {e: sets[f"x{e:g}"] for e in ca.EXPOSURES}, ALL, models)
    features, on, scene, _, visible = sets["fresh"]
    cf, con, cscene, _, cvisible = sets["check"]
    print("fitted on all 260 fresh palettes, threshold at 1 % of their clean scenes, read on the check set:")
    for name, chosen in models.items():
        columns = [ALL.index(c) for c in chosen]
        fitted = ex.fit(features[:, columns], on)
        best, _ = ca.scene_decisions(ex.predict(fitted, features[:, columns]), on, scene, len(visible))
        least = ca.threshold_at(best, visible, 0.01)
        cbest, chit = ca.scene_decisions(ex.predict(fitted, cf[:, columns]), con, cscene, len(cvisible))
        taken = cbest >= least
        print(f"  {name:22s} found {int(np.sum(taken & chit & cvisible))}/{int(cvisible.sum())} "
              f"({100 * np.mean((taken & chit)[cvisible]):.2f} %), false TARGET "
              f"{int(np.sum(taken & ~cvisible))}/{int(np.sum(~cvisible))} "
              f"({100 * np.mean(taken[~cvisible]):.2f} %)", flush=True)


if __name__ == "__main__":
    main()
