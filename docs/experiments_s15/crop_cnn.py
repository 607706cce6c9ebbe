"""Fifteenth session, tuning palettes only: does a small CNN that sees a candidate region's pixels score the
close impurities the verifier's twelve features miss? Four tries at hand-made region features added
nothing (docs/experiments_s13/chroma_features.py, nonlinear.py, docs/experiments_s14/patch_contrast.py);
in 61 of 75 close misses on tuning palettes the impurity is one of the three candidates, scored too low.
This screens a structural alternative on the same rows, scenes and protocol. Design, fixed before any fit:

Rows: exactly calibrate_attention.verifier_rows' (every candidate region that verifier.candidate_features
gives a feature row, label `on`), recomputed here and checked against patch_contrast's cached rows
(runs/s14/patch_<name>.npz: twelve columns, on, scene, group). Per row a crop of SIZE x SIZE px (2 mm/px:
64 mm) centred on the region's centroid (rounded), zero outside the map, channels:
- 0-2 colour: per channel log((c + 1) / (m + 1)), m the median of that channel over the scene's object
  cells (height > occupied_height), clipped to +-COLOUR_CLIP and x COLOUR_SCALE; 0 off the object cells.
  The scene's own product reference: neither the palette's colour nor the exposure enters (a saturated
  channel stays clipped, as in the features);
- 3 the region's mask; 4 the objects mask; 5 height above the table / HEIGHT_SCALE, clipped to
  [0, HEIGHT_CLIP] (unseen cells 0).
No palette identity or absolute colour enters.

The CNN (CropNet, 14 833 parameters): conv 3x3 6->16, ReLU, max-pool 2; conv 3x3 16->32, ReLU, max-pool 2;
conv 3x3 32->32, ReLU (8 x 8); head: the last map's mean over the region (mask average-pooled to 8 x 8 as
weights) and over the other object cells, concatenated (64) -> linear -> logit: "this region against the
objects around it", with learned local features. Adam (LR, WEIGHT_DECAY), cosine decay to 0 over EPOCHS
epochs of batches of BATCH, binary cross-entropy, seed SEED (torch and the shuffling); each batch turned by
a random multiple of 90 degrees and flipped at random. Prediction: the mean logit over the four 90-degree
turns. Crops cached in runs/s15/cnn/crops_<name>.npz, each fit's logits in runs/s15/cnn/logits_<fit>.npz.

Fits (folds: GroupKFold(VERIFIER_FOLDS) by palette on the shipped fit's rows, as nonlinear.cv):
- out<k>: trained on the folds other than k: fold k's logits (its palettes unseen) and the others' own;
- pair<j><k> (j < k): trained on the folds other than j and k: the logits of folds j and k, each from a
  model that saw neither that row's palettes nor the outer test fold;
- full: trained on all the rows: the fresh sets' logits and the fitting rows' own.

Compared (all on the same scenes; the scene decision: the likeliest candidate at or over the threshold; the
threshold the least that lets through `cap` of the fitting scenes without a visible impurity, caps 1 % and
2 %):
- logistic: the twelve features, the shipped form (nonlinear.models()["logistic"]);
- cnn: the CNN alone, its threshold on its own training rows' probabilities (the protocol every model so far
  had: in-sample);
- cnn/oof-thr: the same CNN, its threshold on out-of-fold logits of the fitting rows instead (cv: the
  training rows' pair<j><k> logits; fresh: out<k>'s): an overfitted in-sample score would set the threshold
  too low, so both are shown;
- logistic+cnn: the logistic on the twelve features and the CNN's logit, every fitting row's logit from a
  model not trained on its palette group (cv: training rows pair<j><k>, test rows out<k>; fresh: fitted
  rows out<k>, the fresh rows full), threshold on its training rows' probabilities.
Nested CV (cv) and fitted on all fitting rows, scored on the fresh tuning palette sets random-500+ and
random-600+ (fresh); then the same on the random palettes whose impurity lies within CLOSE dE of the product
(by_delta_e.closeness via patch_contrast.close_scenes), and which close visible scenes each finds that the
logistic misses at the same cap (and the reverse).

    OMP_NUM_THREADS=1 nice -n 15 python docs/experiments_s15/crop_cnn.py cv [--caps=0.01,0.02]
    OMP_NUM_THREADS=1 nice -n 15 python docs/experiments_s15/crop_cnn.py fresh 500 600 [--caps=0.01,0.02]
    OMP_NUM_THREADS=1 nice -n 15 python docs/experiments_s15/crop_cnn.py smoke   # every 60th scene, 1 epoch

Every record's palette must be of the tuning group (or the default palette): the script refuses any other.
"""
import os
import pathlib
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from torch import nn  # noqa: E402

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
sys.path.insert(0, "docs/experiments_s13")
sys.path.insert(0, "docs/experiments_s14")
import calibrate_attention as ca  # noqa: E402
import nonlinear  # noqa: E402
import patch_contrast  # noqa: E402
from patch_contrast import CLOSE, close_scenes, rate  # noqa: E402

from impurity_attention.core.attention import AttentionParams, salient_regions, scene_maps  # noqa: E402
from impurity_attention.core.verifier import TOP_REGIONS, candidate_features  # noqa: E402
from impurity_learning.splits import palette_group  # noqa: E402

CACHE = pathlib.Path("runs/s15/cnn")
SIZE = 32  # px crop side (2 mm/px)
COLOUR_CLIP, COLOUR_SCALE = 1.0, 4.0  # log colour ratio clipped to +-this, then scaled
HEIGHT_SCALE, HEIGHT_CLIP = 0.05, 3.0  # m; height channel = height / HEIGHT_SCALE in [0, HEIGHT_CLIP]
CHANNELS = 6
EPOCHS, BATCH, LR, WEIGHT_DECAY, SEED = 12, 64, 2e-3, 1e-4, 0
CAPS = (0.01, 0.02)
FOLDS = ca.VERIFIER_FOLDS
SMOKE_EVERY, SMOKE_EPOCHS = 60, 1
NAMES = ("logistic", "cnn", "cnn/oof-thr", "logistic+cnn")


def say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


# ---------------------------------------------------------------- crops

def scene_planes(record, objects: np.ndarray) -> np.ndarray:
    """(CHANNELS, H, W) float32 of the scene, the region channel 0 (module docstring)."""
    color = record.color.astype(np.float32)
    reference = np.median(color[objects], axis=0)
    ratio = np.clip(np.log((color + 1.0) / (reference + 1.0)), -COLOUR_CLIP, COLOUR_CLIP) * COLOUR_SCALE
    ratio[~objects] = 0.0
    height = np.nan_to_num(record.height.astype(np.float32), nan=0.0)
    height = np.clip(height / HEIGHT_SCALE, 0.0, HEIGHT_CLIP)
    planes = np.zeros((CHANNELS,) + objects.shape, np.float32)
    planes[0:3] = ratio.transpose(2, 0, 1)
    planes[4] = objects
    planes[5] = height
    return planes


def crop_at(planes: np.ndarray, region: np.ndarray, centre: tuple) -> np.ndarray:
    """(CHANNELS, SIZE, SIZE): `planes` with `region` as channel 3, centred on `centre` (row, col), zero
    outside the map."""
    half = SIZE // 2
    row, col = int(round(centre[0])), int(round(centre[1]))
    out = np.zeros((CHANNELS, SIZE, SIZE), np.float32)
    rows, cols = planes.shape[1:]
    r0, c0 = row - half, col - half
    a0, b0 = max(r0, 0), max(c0, 0)
    a1, b1 = min(r0 + SIZE, rows), min(c0 + SIZE, cols)
    if a1 > a0 and b1 > b0:
        out[:, a0 - r0:a1 - r0, b0 - c0:b1 - c0] = planes[:, a0:a1, b0:b1]
        out[3, a0 - r0:a1 - r0, b0 - c0:b1 - c0] = region[a0:a1, b0:b1]
    return out


CROP_KEYS = ("crops", "features", "on", "scene", "group", "visible", "palettes", "source")


def crops(name: str, records_of, every: int = 1, cache: pathlib.Path = CACHE) -> dict:
    """The rows of verifier_rows with their crops, of every `every`-th kept scene (source: its index among
    all kept scenes, scene: among these), cached in cache / crops_<name>.npz; checked against
    patch_contrast's cached rows."""
    path = cache / f"crops_{name}.npz"
    if not path.exists():
        params = AttentionParams()
        records = records_of()
        groups = {palette_group(r.palette) for r in records}
        if not groups <= {"tuning", "default"}:
            raise SystemExit(f"refusing {name}: palette groups {sorted(groups)} (tuning palettes only)")
        out = {k: [] for k in CROP_KEYS}
        kept = 0
        started = time.perf_counter()
        for number, record in enumerate(records):
            category = record.category()
            if category not in ("visible", "no_impurity", "invisible"):
                continue
            kept += 1
            if (kept - 1) % every:
                continue
            index = len(out["visible"])
            out["visible"].append(category == "visible")
            out["palettes"].append(record.palette or "blocks")
            objects = record.height > params.density.occupied_height
            saliency, conspicuity = scene_maps(record.color, objects, params)
            regions = salient_regions(saliency, objects, params)
            planes = scene_planes(record, objects) if objects.any() else None
            for region, row in candidate_features(record.color, record.height, objects, conspicuity, regions):
                if row is None:
                    continue
                out["crops"].append(crop_at(planes, region.mask, region.centroid).astype(np.float16))
                out["features"].append(row)
                on = category == "visible" and bool(np.any(region.mask & record.visible_target_cells))
                out["on"].append(on)
                out["scene"].append(index)
                out["group"].append(record.palette or "blocks")
                out["source"].append(kept - 1)
            if number % 500 == 0:
                say(f"  crops {name}: {number}/{len(records)} records, {len(out['on'])} rows, "
                    f"{time.perf_counter() - started:.0f} s")
        result = {k: np.array(v) for k, v in out.items()}
        result["on"], result["visible"] = result["on"].astype(bool), result["visible"].astype(bool)
        cache.mkdir(parents=True, exist_ok=True)
        np.savez(path, **result)
        say(f"  crops {name}: {len(result['on'])} rows of {len(result['visible'])} scenes, "
            f"{time.perf_counter() - started:.0f} s")
    data = dict(np.load(path))
    check_rows(name, data)
    return data


def check_rows(name: str, data: dict) -> None:
    """The rows must be patch_contrast's (its cache, when there): twelve columns, on, group, scene."""
    reference = patch_contrast.CACHE / f"patch_{name}.npz"
    if not reference.exists():
        say(f"  {name}: no {reference} to check against")
        return
    old = np.load(reference)
    chosen = np.isin(old["scene"], data["source"])
    same = (int(chosen.sum()) == len(data["on"]) and bool(np.all(old["on"][chosen] == data["on"]))
            and bool(np.all(old["group"][chosen] == data["group"]))
            and bool(np.all(old["scene"][chosen] == data["source"])))
    gap = float(np.max(np.abs(old["features"][chosen, :12] - data["features"]))) if same else float("nan")
    say(f"  {name}: rows against {reference}: same rows {same}, max |diff| {gap:.2e}")
    if not same or gap > 1e-9:
        raise SystemExit(f"{name}: rows differ from {reference}")


# ---------------------------------------------------------------- the CNN

class CropNet(nn.Module):
    def __init__(self):
        super().__init__()
        self.conv1 = nn.Conv2d(CHANNELS, 16, 3, padding=1)
        self.conv2 = nn.Conv2d(16, 32, 3, padding=1)
        self.conv3 = nn.Conv2d(32, 32, 3, padding=1)
        self.out = nn.Linear(64, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        region, objects = x[:, 3:4], x[:, 4:5]
        h = nn.functional.max_pool2d(torch.relu(self.conv1(x)), 2)
        h = nn.functional.max_pool2d(torch.relu(self.conv2(h)), 2)
        h = torch.relu(self.conv3(h))
        own = nn.functional.avg_pool2d(region, 4)
        others = nn.functional.avg_pool2d(objects, 4) * (1.0 - own)
        inside = (h * own).sum((2, 3)) / (own.sum((2, 3)) + 1e-3)
        around = (h * others).sum((2, 3)) / (others.sum((2, 3)) + 1e-3)
        return self.out(torch.cat([inside, around], 1))[:, 0]


def train(x: np.ndarray, y: np.ndarray, label: str, epochs: int) -> CropNet:
    torch.manual_seed(SEED)
    rng = np.random.default_rng(SEED)
    net = CropNet()
    optimiser = torch.optim.Adam(net.parameters(), lr=LR, weight_decay=WEIGHT_DECAY)
    steps = epochs * -(-len(y) // BATCH)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, T_max=steps)
    target = torch.from_numpy(y.astype(np.float32))
    started = time.perf_counter()
    net.train()
    for epoch in range(epochs):
        order, total = rng.permutation(len(y)), 0.0
        for first in range(0, len(y), BATCH):
            chosen = order[first:first + BATCH]
            batch = torch.from_numpy(x[chosen].astype(np.float32))
            batch = torch.rot90(batch, int(rng.integers(4)), (2, 3))
            if rng.integers(2):
                batch = batch.flip(3)
            loss = nn.functional.binary_cross_entropy_with_logits(net(batch), target[chosen])
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            schedule.step()
            total += float(loss) * len(chosen)
        say(f"    {label} epoch {epoch + 1}/{epochs}: loss {total / len(y):.4f}, "
            f"{time.perf_counter() - started:.0f} s")
    return net


def predict(net: CropNet, x: np.ndarray) -> np.ndarray:
    """Mean logit over the four 90-degree turns."""
    net.eval()
    out = np.zeros(len(x))
    with torch.no_grad():
        for first in range(0, len(x), 512):
            batch = torch.from_numpy(x[first:first + 512].astype(np.float32))
            out[first:first + 512] = np.mean([net(torch.rot90(batch, k, (2, 3))).numpy() for k in range(4)],
                                             axis=0)
    return out


def fold_of(data: dict) -> np.ndarray:
    from sklearn.model_selection import GroupKFold
    fold = np.full(len(data["on"]), -1)
    for k, (_, test) in enumerate(GroupKFold(n_splits=FOLDS).split(data["features"], data["on"],
                                                                    data["group"])):
        fold[test] = k
    return fold


def fitted(tag: str, x: np.ndarray, y: np.ndarray, train_rows: np.ndarray, predict_sets: dict,
           cache: pathlib.Path, epochs: int) -> dict:
    """{set name: logits (NaN where not asked)} of the CNN fitted on x[train_rows] (cached by tag);
    predict_sets: {set name: (crops, rows to predict (bool))}."""
    path = cache / f"logits_{tag}.npz"
    if path.exists():
        return dict(np.load(path))
    started = time.perf_counter()
    net = train(x[train_rows], y[train_rows], tag, epochs)
    out = {}
    for name, (crops_, rows) in predict_sets.items():
        logits = np.full(len(crops_), np.nan)
        logits[rows] = predict(net, crops_[rows])
        out[name] = logits
    cache.mkdir(parents=True, exist_ok=True)
    np.savez(path, **out)
    say(f"  fit {tag}: {int(train_rows.sum())} rows, {time.perf_counter() - started:.0f} s")
    return out


def cv_logits(data: dict, cache: pathlib.Path, epochs: int, pairs: bool = True) -> tuple:
    """(out (FOLDS, N): out<k>'s logits on every fitting row, inner (FOLDS, N): for outer fold k, a row of
    fold j != k gets pair<j><k>'s logit, NaN on fold k; all NaN without `pairs`)."""
    x, y, fold = data["crops"], data["on"], fold_of(data)
    count = len(y)
    out = np.full((FOLDS, count), np.nan)
    inner = np.full((FOLDS, count), np.nan)
    for k in range(FOLDS):
        out[k] = fitted(f"out{k}", x, y, fold != k, {"shipped": (x, np.ones(count, bool))}, cache,
                        epochs)["shipped"]
    for j in range(FOLDS if pairs else 0):
        for k in range(j + 1, FOLDS):
            both = (fold == j) | (fold == k)
            logits = fitted(f"pair{j}{k}", x, y, ~both, {"shipped": (x, both)}, cache, epochs)["shipped"]
            inner[k, fold == j] = logits[fold == j]
            inner[j, fold == k] = logits[fold == k]
    return out, inner


# ---------------------------------------------------------------- evaluation

def sigmoid(z: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-z))


def logistic():
    return nonlinear.models()["logistic"]()


def cv_report(data: dict, close: np.ndarray, out: np.ndarray, inner: np.ndarray, caps) -> None:
    features, on, scene, visible = data["features"], data["on"], data["scene"], data["visible"]
    fold, count = fold_of(data), len(visible)
    print(f"{count} scenes, {len(on)} regions, {len(set(data['group']))} palettes")
    decided = {(n, c): np.zeros(count, bool) for n in NAMES for c in caps}
    hits = {n: np.zeros(count, bool) for n in NAMES}
    for k in range(FOLDS):
        train, test = fold != k, fold == k
        stacked = np.column_stack([features, inner[k]])
        stacked_test = np.column_stack([features, out[k]])[test]
        base = logistic().fit(features[train], on[train])
        both = logistic().fit(stacked[train], on[train])
        scores = {  # name: (training rows' probabilities for the threshold, test rows')
            "logistic": (base.predict_proba(features[train])[:, 1], base.predict_proba(features[test])[:, 1]),
            "cnn": (sigmoid(out[k][train]), sigmoid(out[k][test])),
            "cnn/oof-thr": (sigmoid(inner[k][train]), sigmoid(out[k][test])),
            "logistic+cnn": (both.predict_proba(stacked[train])[:, 1],
                             both.predict_proba(stacked_test)[:, 1]),
        }
        seen, unseen = np.zeros(count, bool), np.zeros(count, bool)
        seen[scene[train]], unseen[scene[test]] = True, True
        for name, (own, other) in scores.items():
            own_best, _ = ca.scene_decisions(own, on[train], scene[train], count)
            best, hit = ca.scene_decisions(other, on[test], scene[test], count)
            hits[name][unseen] = hit[unseen]
            for cap in caps:
                least = ca.threshold_at(own_best[seen], visible[seen], cap)
                decided[name, cap] |= (best >= least) & unseen
    everything = np.ones(count, bool)
    for cap in caps:
        for name in NAMES:
            print(f"  {name:12s} cap {100 * cap:.0f} % nested CV: "
                  f"{rate(decided[name, cap], hits[name], visible, everything)}")
    print(f"  -- random palettes within {CLOSE:.0f} dE of the product ({len(set(data['palettes'][close]))} "
          f"palettes, {int(np.sum(close & visible))} visible scenes):")
    for cap in caps:
        for name in NAMES:
            print(f"  {name:12s} cap {100 * cap:.0f} % nested CV: "
                  f"{rate(decided[name, cap], hits[name], visible, close)}")
    print("  -- close visible scenes found by one and not by the logistic at the same cap (and the reverse):")
    for cap in caps:
        base = decided["logistic", cap] & hits["logistic"] & visible & close
        line = f"  cap {100 * cap:.0f} %:"
        for name in NAMES[1:]:
            mine = decided[name, cap] & hits[name] & visible & close
            line += f"  {name} +{int(np.sum(mine & ~base))} -{int(np.sum(base & ~mine))}"
        print(line)


def fresh_report(data: dict, out: np.ndarray, fold: np.ndarray, full: dict, sets: dict, caps) -> None:
    """sets: {first: crops dict}; full: full's logits {"shipped": ..., "fresh<first>": ...}."""
    features, on, scene, visible = data["features"], data["on"], data["scene"], data["visible"]
    oof = out[fold, np.arange(len(on))]
    base = logistic().fit(features, on)
    both = logistic().fit(np.column_stack([features, oof]), on)
    fitting = {  # name: the fitting rows' probabilities the threshold is taken on
        "logistic": base.predict_proba(features)[:, 1],
        "cnn": sigmoid(full["shipped"]),
        "cnn/oof-thr": sigmoid(oof),
        "logistic+cnn": both.predict_proba(np.column_stack([features, oof]))[:, 1],
    }

    def scored(name, first):
        f, logits = sets[first], full[f"fresh{first}"]
        if name == "logistic":
            return base.predict_proba(f["features"])[:, 1]
        if name == "logistic+cnn":
            return both.predict_proba(np.column_stack([f["features"], logits]))[:, 1]
        return sigmoid(logits)

    decisions = {}  # (name, cap, first): (decided, hit)
    for name in NAMES:
        best, _ = ca.scene_decisions(fitting[name], on, scene, len(visible))
        for cap in caps:
            least = ca.threshold_at(best, visible, cap)
            line = f"  {name:12s} cap {100 * cap:.0f} % threshold {least:.3f}:"
            for first, f in sets.items():
                p_best, p_hit = ca.scene_decisions(scored(name, first), f["on"], f["scene"],
                                                   len(f["visible"]))
                decisions[name, cap, first] = (p_best >= least, p_hit)
                v = f["visible"]
                line += (f"  random-{first}+ found {100 * np.mean((p_best >= least)[v] & p_hit[v]):5.1f} % "
                         f"false TARGET {100 * np.mean((p_best >= least)[~v]):.1f} %")
            print(line)
    print(f"  -- random palettes within {CLOSE:.0f} dE of the product:")
    near = {first: close_scenes(f["palettes"]) for first, f in sets.items()}
    for name in NAMES:
        for cap in caps:
            line = f"  {name:12s} cap {100 * cap:.0f} %:"
            for first, f in sets.items():
                d, h = decisions[name, cap, first]
                line += f"  random-{first}+ {rate(d, h, f['visible'], near[first])}"
            print(line)
    print("  -- close visible scenes found by one and not by the logistic at the same cap (and the reverse):")
    for cap in caps:
        line = f"  cap {100 * cap:.0f} %:"
        for first, f in sets.items():
            d, h = decisions["logistic", cap, first]
            reference = d & h & f["visible"] & near[first]
            line += f"  random-{first}+"
            for name in NAMES[1:]:
                d, h = decisions[name, cap, first]
                mine = d & h & f["visible"] & near[first]
                line += f" {name} +{int(np.sum(mine & ~reference))} -{int(np.sum(reference & ~mine))}"
        print(line)


def full_logits(data: dict, sets: dict, cache: pathlib.Path, epochs: int) -> dict:
    predict_sets = {"shipped": (data["crops"], np.ones(len(data["on"]), bool))}
    predict_sets.update({f"fresh{first}": (f["crops"], np.ones(len(f["on"]), bool))
                         for first, f in sets.items()})
    path = cache / "logits_full.npz"
    if path.exists() and set(np.load(path).files) != set(predict_sets):
        raise SystemExit(f"{path} holds {sorted(np.load(path).files)}: remove it to predict "
                         f"{sorted(predict_sets)}")
    everything = np.ones(len(data["on"]), bool)
    return fitted("full", data["crops"], data["on"], everything, predict_sets, cache, epochs)


def main() -> None:
    import fresh_tuning_palettes
    started = time.perf_counter()
    torch.set_num_threads(1)
    cv2.setNumThreads(1)
    command, rest = sys.argv[1], sys.argv[2:]
    assert TOP_REGIONS == 3
    caps = [float(c) for a in rest if a.startswith("--caps=") for c in a[len("--caps="):].split(",")] or CAPS
    smoke = command == "smoke"
    every, epochs = (SMOKE_EVERY, SMOKE_EPOCHS) if smoke else (1, EPOCHS)
    cache = CACHE / "smoke" if smoke else CACHE
    say(f"# torch {torch.__version__}, threads {torch.get_num_threads()}, OMP_NUM_THREADS "
        f"{os.environ.get('OMP_NUM_THREADS')}, {sum(p.numel() for p in CropNet().parameters())} parameters")
    data = crops("shipped", nonlinear.shipped_records, every, cache)
    close = close_scenes(data["palettes"])
    firsts = [500, 600] if smoke else [int(a) for a in rest if a.isdigit()]
    sets = {first: crops(f"fresh{first}", lambda f=first: fresh_tuning_palettes.fresh_records(f, 60), every,
                         cache) for first in firsts} if command != "cv" else {}
    out, inner = cv_logits(data, cache, epochs, pairs=command != "fresh")
    if command in ("cv", "smoke"):
        print("== 12 features (logistic) / CNN on crops / logistic on 12 features + CNN logit")
        cv_report(data, close, out, inner, caps)
    if command in ("fresh", "smoke"):
        print("== 12 features (logistic) / CNN on crops / logistic on 12 features + CNN logit")
        fresh_report(data, out, fold_of(data), full_logits(data, sets, cache, epochs), sets, caps)
    sys.stdout.flush()
    say(f"# {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
