"""Eighteenth session, tuning data only: a screen for a stall-breaker, on loop views.

stalls.py found challenging episodes that ran into the action limit while the target was in view and was the
verifier's likeliest region for 25 views in a row, at probabilities 0.35-0.73 under the threshold 0.76: a
heap is always left in challenging scenes, so the last look (which waits for no heap) never comes, and the
loop pushes heaps to the end. A stall-breaker would take the likeliest region as a TARGET once the loop has
pushed heaps for K views in a row and that region's probability reaches t.

This screens (K, t) on the views of experiments_s17/loop_views.py (runs/s17/views_{inv,chal,rand}.npz with
their .jsonl; tuning palettes and seeds; the shipped verifier was fitted on them, so its probabilities are
in-sample there): per episode, the first view where the stall-breaker would fire, and whether the region it
would take lies on a target. Replayed offline: the episode after a firing is not simulated, so only the first
firing per episode is counted.

    python docs/experiments_s18/stall_screen.py runs/s17/views_inv.npz runs/s17/views_chal.npz \
        runs/s17/views_rand.npz
"""
import pathlib
import sys
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import stalls  # noqa: E402  (likeliest: the view's mode and the verifier's likeliest region)

KS = (3, 5, 8, 12)
TS = (0.3, 0.4, 0.5, 0.6)


def view_row(record) -> tuple:
    """(episode seed, view index, shipped mode name, likeliest probability or None, on a target):
    stalls.likeliest of a loop view, keyed by its episode."""
    return (record.seed // 100, record.seed % 100, *stalls.likeliest(record))


def main(paths) -> None:
    from impurity_attention.core import evaluation
    records = [r for path in paths for r in evaluation.load_records(path)]
    with ProcessPoolExecutor(2) as pool:
        rows = list(pool.map(view_row, records, chunksize=16))
    episodes = defaultdict(list)
    for seed, index, mode, probability, on in rows:
        episodes[seed].append((index, mode, probability, on))
    print(f"{len(records)} views of {len(episodes)} episodes")
    for k in KS:
        for t in TS:
            on_target = off_target = 0
            for views in episodes.values():
                run = 0
                for _, mode, probability, on in sorted(views):
                    run = run + 1 if mode == "OCCLUDED_REGION" else 0
                    if run >= k and probability is not None and probability >= t:
                        on_target += on
                        off_target += not on
                        break
            print(f"  K {k:2d} views of heap pushing, t {t:.1f}: fires in {on_target + off_target} episodes, "
                  f"on a target {on_target}, off every target {off_target}")


if __name__ == "__main__":
    main(sys.argv[1:])
