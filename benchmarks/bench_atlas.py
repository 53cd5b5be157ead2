"""Atlas throughput: scenes per second of the quasi-static + linear tier with 1 and 2 Dask workers.

Runs the atlas's own task (``compare.atlas.compute.compute_linkage``: every family of a linkage over the
ratio sweep) for the first ``--linkages`` linkages of the sample on a fresh ``distributed.LocalCluster``
of 1, then 2 worker processes, ``--repeats`` times each, and prints the median scenes per second (a
scene = one ratio of one family through both solvers).  Run on purpose, never in the test suite:

    .venv/bin/python benchmarks/bench_atlas.py [--linkages 4] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time

from compare.atlas.compute import NOT_COMPUTED, compute_linkage
from compare.atlas.generate import Linkage, generate


def scenes(records: tuple) -> int:
    """Scenes computed in a linkage's records (ratios not skipped by the sweep's stop rule)."""
    return sum(sum(c != NOT_COMPUTED for c in rec.code) for rec in records)


def one_run(workers: int, linkages: tuple[Linkage, ...]) -> tuple[float, int]:
    """(wall time [s], scenes) of the linkages on a fresh LocalCluster of ``workers`` processes."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=40) as cluster, Client(cluster) as client:
        client.submit(sum, [1]).result()  # workers up and warm before the clock starts
        t0 = time.perf_counter()
        futures = [client.submit(compute_linkage, lk, pure=False) for lk in linkages]
        n = sum(scenes(f.result()) for f in futures)
        return time.perf_counter() - t0, n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--linkages", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    linkages = generate(args.linkages, args.seed).linkages
    print(f"{args.linkages} linkages (seed {args.seed}), {args.repeats} repeats per worker count")
    for workers in (1, 2):
        runs = [one_run(workers, linkages) for _ in range(args.repeats)]
        rates = [n / wall for wall, n in runs]
        print(f"workers={workers}: {runs[0][1]} scenes, wall {statistics.median(w for w, _ in runs):.1f} s (median), "
              f"{statistics.median(rates):.1f} scenes/s (median; runs: {', '.join(f'{r:.1f}' for r in rates)})")


if __name__ == "__main__":
    main()
