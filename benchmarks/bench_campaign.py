"""Campaign throughput with 1 and 2 local worker processes on the same scenes.

Each measurement is a complete :func:`compare.runner.run_campaign` into a fresh results file (pool
start-up, all scenes, every atomic HDF5 commit), as a user experiences ``ked run``.  Reports the median
wall time of ``--repeats`` runs per worker count, scenes per second and the speed-up over 1 worker
(goal: 2 workers >= 1.8x).  The speed-up of the best runs and a pure-CPU 2-process ceiling measured
before and after are printed too: on a shared machine other jobs take cores and the medians drop.

    .venv/bin/python benchmarks/bench_campaign.py [--repeats 3] [--workers 1 2] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from compare import store
from compare.config import parse_config
from compare.runner import run_campaign

CONFIG = """
[campaign]
name = "bench"
step_deg = 10.0
[linkage]
preset = "thesis"
[grid]
mechanisms = ["source", "cognate"]
mass_models = ["joints", "extender", "distributed"]
rpm = [60.0, 120.0, 180.0, 240.0]
[dynamic]
element = "ancf"
elements_per_link = 4
steps_per_cycle = 720
spectral_radius = 0.9
"""


def _burn(n: int) -> int:
    s = 0
    for i in range(n):
        s += i * i
    return s


def cpu_ceiling(n: int = 4_000_000) -> float:
    """Speed-up of a pure-CPU task on 2 processes vs 1, measured now: what this machine (and whatever
    else runs on it) allows; 2.0 on two idle cores."""
    import concurrent.futures as cf
    import multiprocessing

    with cf.ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        list(pool.map(_burn, [1000, 1000]))  # start both workers
        t0 = time.perf_counter()
        list(pool.map(_burn, [n, n]))
        t2 = time.perf_counter() - t0
    t0 = time.perf_counter()
    _burn(n)
    _burn(n)
    t1 = time.perf_counter() - t0
    return t1 / t2


def run_once(workers: int, directory: Path) -> float:
    """Wall time [s] of one complete campaign with ``workers`` processes into a fresh file."""
    out = directory / f"bench_{workers}_{time.monotonic_ns()}.h5"
    t0 = time.perf_counter()
    summary = run_campaign(parse_config(CONFIG), out, workers=workers, progress=False)
    wall = time.perf_counter() - t0
    assert summary.ok + summary.failed == summary.total and not store.verify(out)
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--json", type=Path, default=None, help="also write the numbers to this JSON file")
    args = ap.parse_args()
    n = len(parse_config(CONFIG).scenes())
    print(f"{n} scenes; load average before: {os.getloadavg()[0]:.2f}; "
          f"pure-CPU 2-process ceiling now: {cpu_ceiling():.2f}x", flush=True)
    times: dict[int, list[float]] = {w: [] for w in args.workers}
    with tempfile.TemporaryDirectory() as d:
        for i in range(args.repeats):  # interleaved, so that both counts see the same machine state
            for w in args.workers:
                times[w].append(run_once(w, Path(d)))
                print(f"  round {i + 1}: workers={w} {times[w][-1]:.2f} s", flush=True)
    base_w = min(args.workers)
    rows = {}
    for w in args.workers:
        med = statistics.median(times[w])
        pair = statistics.median(b / t for b, t in zip(times[base_w], times[w]))
        rows[w] = {"times_s": times[w], "median_s": med, "min_s": min(times[w]), "scenes_per_s": n / med,
                   "speedup": statistics.median(times[base_w]) / med,
                   "speedup_best": min(times[base_w]) / min(times[w]), "speedup_paired": pair}
        print(f"workers={w}: median {med:.2f} s ({n / med:.2f} scenes/s); speed-up over {base_w}: "
              f"{rows[w]['speedup']:.2f}x (medians), {rows[w]['speedup_best']:.2f}x (best runs), "
              f"{pair:.2f}x (median of same-round ratios)")
    ceiling = cpu_ceiling()
    print(f"load average after: {os.getloadavg()[0]:.2f}; pure-CPU 2-process ceiling now: {ceiling:.2f}x")
    if args.json:
        args.json.write_text(json.dumps({"scenes": n, "results": rows, "cpu_ceiling": ceiling}, indent=2))


if __name__ == "__main__":
    main()
