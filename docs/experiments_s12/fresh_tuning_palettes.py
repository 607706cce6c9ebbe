"""Twelfth session, tuning palettes only: how does the shipped verifier do on random palettes of the tuning
range that nothing was fitted or chosen on (random-500 ... 559), on the tuning palettes' layouts?

The verifier was fitted on random-0 ... 95 and the tuning named palettes (97.7 % found in-sample, 97.4 %
palette-grouped cross-validation); held-out sets drawn from the same generator gave 89.2-98.2 %. Fresh tuning
palettes tell whether that gap is a draw of the held-out set or the model's own (and stay tuning data).

    python docs/experiments_s12/fresh_tuning_palettes.py [first] [count]    # default 500 60
"""
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402


def fresh_records(first: int, count: int) -> list:
    """Records of random-<first> ... random-<first + count - 1> on the tuning palettes' layouts (PALETTE_PLAN
    on tuning seeds, as collect_palettes("tuning")), cached in runs/perception/palettes_fresh<first>.npz."""
    palettes = [f"random-{seed}" for seed in range(first, first + count)]
    wanted = ca.palette_scenes(palettes, lambda row, number, scenes: ca.SEED_BASE["tuning"] + 100 * row)
    return ca.render_cached(ca.CACHE / f"palettes_fresh{first}.npz", wanted,
                            f"fresh tuning palettes {first}+")


def main() -> None:
    first = int(sys.argv[1]) if len(sys.argv) > 1 else 500
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 60
    records = fresh_records(first, count)
    print(f"== random-{first} ... {first + count - 1}: tuning palettes nothing was fitted on, tuning layouts")
    ca.print_palette_rates(ca.palette_rates(records, AttentionParams()))


if __name__ == "__main__":
    main()
