"""Twenty-fifth session, tuning data only: does the colour of a false TARGET after pushes look like the
episode's first view? Reads episodes recorded with `push_out.py run ... --mask-truth --temporal` and sorts
TARGET-mode grasps by what their mask showed (mask_precision < 0.5: product; >= 0.9: a target).

    python docs/experiments_s25/temporal_screen.py runs/s25/temporal_*.jsonl [--plot out.png]

For each radius r (t_seen_r: the share of the first view's object cells within dE r of the mask's median
colour) it prints both groups' quantiles and, for bounds b, the share of grasps on a target with t_seen_r <= b
(kept) and the share of grasps on product with t_seen_r > b (caught). The reading rule (docs/experiments.md,
twenty-fifth section): a lead if some bound keeps >= 97 % of the grasps on a target and catches >= 50 % of
those on product.
"""
import json
import sys

import numpy as np


def groups(paths):
    on_product, on_target = [], []
    for path in paths:
        for line in open(path):
            episode = json.loads(line)
            for grasp in episode["grasps"]:
                if grasp["mode"] != "TARGET" or "mask_precision" not in grasp or "t_seen_8" not in grasp:
                    continue
                row = dict(grasp, palette=episode["palette"], seed=episode["seed"])
                if grasp["mask_precision"] < 0.5:
                    on_product.append(row)
                elif grasp["mask_precision"] >= 0.9:
                    on_target.append(row)
    return on_product, on_target


def main(paths) -> None:
    on_product, on_target = groups(paths)
    print(f"TARGET grasps with the mask on product: {len(on_product)} (lifted product "
          f"{sum(g['lifted'] and not g['target'] for g in on_product)}); on a target: {len(on_target)} "
          f"(lifted it {sum(g['target'] for g in on_target)})")
    for r in (4, 8, 12):
        key = f"t_seen_{r}"
        product = np.array([g[key] for g in on_product])
        target = np.array([g[key] for g in on_target])
        q = (0.1, 0.25, 0.5, 0.75, 0.9)
        print(f"== dE {r}: quantiles {q}")
        print("   mask on product:", np.round(np.quantile(product, q), 4) if product.size else "-")
        print("   mask on target: ", np.round(np.quantile(target, q), 4) if target.size else "-")
        for bound in (0.0, 0.001, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2):
            kept = float(np.mean(target <= bound)) if target.size else float("nan")
            caught = float(np.mean(product > bound)) if product.size else float("nan")
            flag = "  <- lead" if kept >= 0.97 and caught >= 0.5 else ""
            print(f"   bound {bound:5.3f}: grasps on a target kept {100 * kept:5.1f} %, on product caught "
                  f"{100 * caught:5.1f} %{flag}")
    print("== grasps on a target above t_seen_8 0.01 (palette, seed, t_seen_8, lifted)")
    for g in sorted(on_target, key=lambda g: -g["t_seen_8"])[:15]:
        if g["t_seen_8"] > 0.01:
            print(f"   {g['palette']:22s} {g['seed']} {g['t_seen_8']:.4f} {g['target']}")
    print("== grasps on product (palette, seed, t_seen_4 / 8 / 12, lifted product)")
    for g in sorted(on_product, key=lambda g: g["t_seen_8"]):
        print(f"   {g['palette']:22s} {g['seed']} {g['t_seen_4']:.4f} {g['t_seen_8']:.4f} "
              f"{g['t_seen_12']:.4f} {g['lifted'] and not g['target']}")


def plot(paths, out: str) -> None:
    """One picture: t_seen_4 of the grasps on a target and of those on product (log scale, zeros left)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    on_product, on_target = groups(paths)
    floor = 1e-4  # zeros drawn here
    bins = np.logspace(-4, 0, 33)
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for rows, label, colour in ((on_target, f"mask on a target ({len(on_target)} grasps)", "tab:green"),
                                (on_product, f"mask on product ({len(on_product)} grasps)", "tab:red")):
        values = np.maximum([g["t_seen_4"] for g in rows], floor)
        ax.hist(values, bins=bins, alpha=0.6, label=label, color=colour)
    ax.axvline(0.01, color="k", linestyle="--", label="known_product_max_share 1 %")
    ax.set_xscale("log")
    ax.set_xlabel("share of the first view's object cells within dE 4 of the mask's colour (0 drawn at 1e-4)")
    ax.set_ylabel("TARGET grasps")
    ax.set_title("Invisible tuning episodes with a grasp on product: how common was the grasped colour?")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    args = sys.argv[1:]
    if "--plot" in args:
        at = args.index("--plot")
        plot(args[:at] + args[at + 2:], args[at + 1])
        args = args[:at] + args[at + 2:]
    main(args)
