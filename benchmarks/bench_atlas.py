"""Atlas throughput: scenes per second of the quasi-static + linear tier on 1 and 2 local Dask workers.

Runs the atlas's own tasks (``ked_research.atlas.run.family_tasks``, ``ked_research.atlas.compute.compute_family``:
one family of a linkage over the ratio sweep per task, as ``ked study atlas`` submits them) for the first
``--linkages`` linkages of the sample on a fresh ``distributed.LocalCluster`` of 1, then 2 worker
processes (one thread each; the nanny's environment as Dask sets it, as on ``ked study atlas --scheduler``;
without a scheduler the atlas runs the same tasks on the harness's own process pool), ``--repeats``
times each.  A scene is one ratio of one family through both solvers (ratios skipped by the sweep's stop
rule are not counted).  The workers have imported the harness before the clock starts (a long atlas run
pays that once per worker); the clock runs from the first submission to the last result, so the rate
includes the scheduling, the transfer of the records and the wait for the last task.

Printed per worker count: scenes, the median wall time and scenes/s, and the CPU seconds per scene spent
inside the tasks (summed over the workers: the cost of a scene whatever else runs on the machine; the
wall rate on a busy machine is lower than on an idle one).

With ``--against DIR`` (another checkout, e.g. ``git worktree add /tmp/old main``) the same runs are
made with the workers importing the harness from DIR, in turn with this checkout's (same load): both
rates and their ratio.  Run on purpose, never in the test suite:

    .venv/bin/python benchmarks/bench_atlas.py [--linkages 4] [--repeats 3] [--against DIR]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def _atlas(tree: str, module: str):
    """Module ``module`` of the atlas package of checkout ``tree`` (``ked_research.atlas``; ``compare.atlas`` in a
    checkout older than the research package)."""
    import importlib

    package = "ked_research.atlas" if (Path(tree) / "ked_research" / "atlas").is_dir() else "compare.atlas"
    return importlib.import_module(f"{package}.{module}")


def _warm(tree: str, n: int, seed: int) -> tuple[str, list[tuple[int, int | None]]]:
    """On a worker, before the clock starts: import the harness from ``tree``; returns where it was found
    and the atlas's tasks of that checkout, (linkage i, family j), or (i, None) for a task per linkage."""
    import sys

    sys.path.insert(0, tree)
    import compare.solvers.linear
    import compare.solvers.quasi_static  # noqa: F401

    compute, run = _atlas(tree, "compute"), _atlas(tree, "run")
    linkages = _atlas(tree, "generate").generate(n, seed).linkages
    if not hasattr(run, "family_tasks"):  # a checkout whose atlas task is a linkage
        return compute.__file__, [(i, None) for i in range(n)]
    return compute.__file__, [(i, j) for i, lk in enumerate(linkages) for j in range(len(run.family_tasks([lk])))]


def _task(tree: str, n: int, seed: int, i: int, j: int | None) -> tuple[int, float]:
    """(scenes, CPU s) of task (i, j) of :func:`_warm`, on a worker: only plain numbers travel back, so two
    checkouts' workers can be compared by one client."""
    compute, run = _atlas(tree, "compute"), _atlas(tree, "run")
    linkage = _atlas(tree, "generate").generate(n, seed).linkages[i]
    c0 = time.process_time()
    if j is None:
        records = compute.compute_linkage(linkage)
    else:
        records = (compute.compute_family(*run.family_tasks([linkage])[j]),)
    return sum(sum(c != compute.NOT_COMPUTED for c in rec.code) for rec in records), time.process_time() - c0


def one_run(workers: int, n: int, seed: int, tree: Path) -> tuple[float, int, float]:
    """(wall time [s], scenes, CPU s in the tasks) of the first ``n`` linkages on a fresh LocalCluster of
    ``workers`` processes importing the harness from ``tree``."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=40) as cluster, Client(cluster) as client:
        warm = client.run(_warm, str(tree), n, seed)  # workers up, harness imported, before the clock starts
        where = {w for w, _ in warm.values()}
        if len(where) != 1 or not Path(next(iter(where))).is_relative_to(tree):
            raise SystemExit(f"the workers imported the harness from {where}, not from {tree}")
        tasks = next(iter(warm.values()))[1]
        t0 = time.perf_counter()
        futures = [client.submit(_task, str(tree), n, seed, i, j, pure=False) for i, j in tasks]
        done = [f.result() for f in futures]
        return time.perf_counter() - t0, sum(s for s, _ in done), sum(c for _, c in done)


def summary(runs: list[tuple[float, int, float]]) -> tuple[float, str]:
    rates = [s / wall for wall, s, _ in runs]
    med = statistics.median(rates)
    return med, (f"{runs[0][1]} scenes, wall {statistics.median(w for w, _, _ in runs):.1f} s, {med:.1f} scenes/s "
                 f"(runs: {', '.join(f'{r:.1f}' for r in rates)}), "
                 f"{1e3 * statistics.median(c / s for _, s, c in runs):.1f} CPU ms/scene")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--linkages", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", default="1,2", help="worker counts, comma-separated")
    ap.add_argument("--against", default=None, metavar="DIR", help="also time the checkout in DIR, in turn")
    args = ap.parse_args()
    trees = {"this": HERE} | ({"against": Path(args.against).resolve()} if args.against else {})
    for tree in trees.values():
        if not any((tree / d / "atlas" / "compute.py").is_file() for d in ("ked_research", "compare")):
            raise SystemExit(f"--against {tree}: not a ked-harness checkout (no atlas/compute.py)")
    print(f"{args.linkages} linkages (seed {args.seed}), {args.repeats} repeats per worker count"
          + (f"; this checkout ({HERE}) and {trees['against']} in turn" if args.against else ""))
    for workers in (int(w) for w in args.workers.split(",")):
        runs: dict[str, list[tuple[float, int, float]]] = {name: [] for name in trees}
        for _ in range(args.repeats):
            for name, tree in trees.items():
                runs[name].append(one_run(workers, args.linkages, args.seed, tree))
        rates = {}
        for name in trees:
            rates[name], text = summary(runs[name])
            print(f"workers={workers} {name:>7}: {text}")
        if args.against:
            print(f"workers={workers}   ratio: {rates['this'] / rates['against']:.2f}x the scenes/s of {args.against}")


if __name__ == "__main__":
    main()
