"""`ked diff` of a results file against itself: wall time of the command (a fresh process, imports included) and
of the comparison alone, on the default campaign's file and on a 10 000-scene file.

    .venv/bin/python benchmarks/bench_diff.py [FILE] [--scenes 10000]

FILE defaults to ked_results/thesis-default.h5 (written by `ked run`), else the committed
results/studies/linear_acceptance.h5 (the default campaign's 40 scenes, three solvers, 10 deg grid, with a finer
Exudyn reference: the same shapes).  The large file is made from FILE's scenes, each repeated at other stiffness
scales (distinct scenes, the same histories), written by the store in a temporary directory.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "ked_results" / "thesis-default.h5"
FALLBACK = ROOT / "results" / "studies" / "linear_acceptance.h5"
KED = Path(sys.executable).with_name("ked")


def cli_time(path: Path, repeat: int = 3) -> float:
    """Median wall time [s] of `ked diff FILE FILE` in a fresh process."""
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        subprocess.run([str(KED), "diff", str(path), str(path)], check=True, capture_output=True)
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def api_time(path: Path) -> tuple[float, int]:
    from compare.diff import diff_files

    t = time.perf_counter()
    rep = diff_files(path, path)
    assert rep.passed
    return time.perf_counter() - t, len(rep.scenes)


def large_file(src: Path, n: int, out: Path) -> Path:
    """A results file of ``n`` scenes: ``src``'s scenes at stiffness scales 1 + i 1e-4 (distinct keys)."""
    from compare import store

    base = store.read_scenes(src)
    store.record_run(out, "", "bench-diff", n)
    batch = []
    for i in range(n):
        r = base[i % len(base)]
        spec = dataclasses.replace(r.spec, stiffness_scale=1.0 + (i // len(base)) * 1e-4)
        batch.append(dataclasses.replace(r, spec=spec))
        if len(batch) == 1000:
            store.commit(out, batch)
            batch = []
    if batch:
        store.commit(out, batch)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", type=Path, default=DEFAULT if DEFAULT.exists() else FALLBACK)
    ap.add_argument("--scenes", type=int, default=10_000, help="scenes of the large file (0: skip it)")
    args = ap.parse_args()
    t, n = api_time(args.file)
    print(f"{args.file}: {n} scenes; ked diff FILE FILE {cli_time(args.file):.2f} s (fresh process, median of 3); "
          f"comparison alone {t:.2f} s")
    if args.scenes:
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            big = large_file(args.file, args.scenes, Path(d) / "large.h5")
            made = time.perf_counter() - t0
            t, n = api_time(big)
            print(f"{n} scenes (file written in {made:.0f} s): ked diff FILE FILE {cli_time(big, 1):.1f} s; "
                  f"comparison alone {t:.1f} s")


if __name__ == "__main__":
    main()
