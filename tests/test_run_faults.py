"""Faults around a running campaign, through the real command line in subprocesses: repeated
signals, a hang-up, Ctrl-C while the workers start, a disk that fills, kill -9 while figures are
drawn, peers that are not a Dask scheduler, a script without a main guard, figure directories that
hold the user's own files, and odd paths (FIFOs, symlink loops).  Each must end promptly, in one line
without a traceback, with a non-zero exit status, and keep everything committed.
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from compare import store
from compare.config import parse_config
from compare.runner import run_campaign

from .test_edges import QS, SLOW, _alive, _children, _cmdline, _mount, assert_one_line_error, ked

KED = [sys.executable, "-m", "ked_cli"]


@pytest.fixture(scope="module")
def qs_results(tmp_path_factory) -> Path:
    """A small complete results file (quasi-static only: quick)."""
    out = tmp_path_factory.mktemp("stored") / "edges.h5"
    run_campaign(parse_config(QS), out, workers=1, progress=False)
    return out


@pytest.fixture()
def qs_config(tmp_path) -> Path:
    p = tmp_path / "edges.toml"
    p.write_text(QS)
    return p


def _default_sigint() -> None:
    """A shell runs background jobs with SIGINT ignored (and nohup, SIGHUP), and Python keeps them ignored,
    as ked does on purpose (a hang-up under nohup must not stop a run): give the child the default handlers,
    as a terminal's foreground job has, whatever the test run was started under."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def _start(args: list[str], **kw) -> subprocess.Popen:
    kw = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "preexec_fn": _default_sigint, **kw}
    return subprocess.Popen([*KED, *args], text=True, **kw)


def _workers_of(proc: subprocess.Popen, n: int, until: Path | None = None, limit_s: float = 120) -> set[int]:
    """The spawned worker processes of ``proc`` once ``n`` exist (and ``until`` exists, if given)."""
    deadline = time.monotonic() + limit_s
    workers: set[int] = set()
    while time.monotonic() < deadline and not (len(workers) >= n and (until is None or until.exists())):
        workers |= {c for c in _children(proc.pid) if "spawn_main" in _cmdline(c)}
        time.sleep(0.05)
    return workers


def _gone(pids: set[int], limit_s: float = 10) -> bool:
    t0 = time.monotonic()
    while any(_alive(p) for p in pids) and time.monotonic() - t0 < limit_s:
        time.sleep(0.1)
    return not any(_alive(p) for p in pids)


def _finish(proc: subprocess.Popen, limit_s: float = 60) -> tuple[str, str]:
    """Output of ``proc``; a process still running after ``limit_s`` hangs: kill it, fail the test."""
    try:
        return proc.communicate(timeout=limit_s)
    except subprocess.TimeoutExpired:
        for c in _children(proc.pid):
            os.kill(c, signal.SIGKILL)
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"hangs: still running {limit_s:g} s after the signal; stderr: {err[-800:]}")


# -- signals ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("sigs", [(signal.SIGINT, signal.SIGINT), (signal.SIGTERM, signal.SIGTERM),
                                  (signal.SIGHUP,)], ids=["int-int", "term-term", "hup"])
def test_repeated_signals_or_hangup_end_the_run_promptly_and_keep_the_commits(tmp_path, sigs):
    cfg = tmp_path / "signals.toml"
    cfg.write_text(SLOW)
    out = tmp_path / "signals.h5"
    proc = _start(["run", str(cfg), "--out", str(out), "--workers", "2", "--no-progress", "--no-figures"])
    workers = _workers_of(proc, 2, until=out)
    assert workers, "no worker process started"
    time.sleep(1.0)  # the workers are computing
    for s in sigs:
        proc.send_signal(s)
        time.sleep(0.3)
    _, err = _finish(proc)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("ked: interrupted"), err
    assert _gone(workers), "worker processes outlived ked run"
    assert store.verify(out) == []  # what was committed stays, readable (a rerun resumes from it)


def test_ctrl_c_stops_a_check_and_its_workers_in_one_line():
    # `ked check` over a range of the distributed model starts worker processes (its work is worth them);
    # a Ctrl-C to the process group while they compute ends it in one line, which says that a check keeps
    # nothing (it stores no results), and takes the workers with it
    # (60 speeds at 10 lumps a link: worth the workers on any machine; 20 speeds at 5 lumps ran in 6 s and
    # started none on this project's machine)
    proc = _start(["check", "--mass-model", "distributed", "--lumps", "10", "--rpm-range", "30:600:60", "--workers",
                   "2"],
                  start_new_session=True)
    workers = _workers_of(proc, 2)
    assert workers, "no worker process started"
    time.sleep(0.5)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = _finish(proc)
    assert proc.returncode == 130, err
    assert err.strip() == "ked: interrupted; nothing was stored", err
    assert _gone(workers)


def test_the_interrupt_line_names_what_is_kept():
    from ked_cli.errors import interrupted

    assert interrupted(["run", "c.toml", "--workers", "2"]).endswith("(rerun to resume)")
    assert interrupted(["--no-color", "study", "atlas"]).endswith("(rerun to resume)")
    assert interrupted(["check", "--rpm", "100"]) == interrupted(["quasi"]) == "ked: interrupted; nothing was stored"


def test_ctrl_c_while_the_workers_start_prints_no_child_traceback(tmp_path):
    # a terminal's Ctrl-C goes to the whole process group: the parent and its starting workers
    cfg = tmp_path / "signals.toml"
    cfg.write_text(SLOW)
    out = tmp_path / "start.h5"
    proc = _start(["run", str(cfg), "--out", str(out), "--workers", "2", "--no-progress", "--no-figures"],
                  start_new_session=True)
    workers = _workers_of(proc, 1)
    assert workers, "no worker process started"
    os.killpg(proc.pid, signal.SIGINT)
    _, err = _finish(proc)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "Fatal Python error" not in err, err
    # the run's start line comes once the workers are ready (workers import little and may be ready first)
    lines = [ln for ln in err.strip().splitlines() if ln and not ln.startswith("campaign 'signals'")]
    assert len(lines) == 1 and lines[0].startswith("ked: interrupted"), err
    assert _gone(workers)


# -- figures: the user's files are left alone, no orphan draws on ---------------------------------------


def test_figures_never_overwrite_files_the_harness_did_not_write(tmp_path, qs_config, qs_results):
    for name in ("index.json", "amplification.png", "scene_source_tip_60rpm_k1_z0.02_ccw.png"):
        figs = tmp_path / name.replace(".", "_")
        figs.mkdir()
        mine = figs / name
        mine.write_bytes(b"the user's own file\n")
        assert_one_line_error(ked("plot", str(qs_results), "--out", str(figs)), str(mine), "not", code=1)
        if name == "index.json":
            assert_one_line_error(ked("run", str(qs_config), "--out", str(qs_results), "--figures", str(figs),
                                      "--no-progress"), str(mine), "not", code=1)
        assert mine.read_bytes() == b"the user's own file\n" and os.listdir(figs) == [name]
    # figures the harness wrote itself are kept up to date as before
    own = tmp_path / "own"
    assert ked("plot", str(qs_results), "--out", str(own)).returncode == 0
    assert len(list(own.glob("scene_*.png"))) == 4
    res = ked("plot", str(qs_results), "--out", str(own))
    assert res.returncode == 0 and res.stdout.startswith("0 PNG files"), res.stdout


MANY = QS.replace('rpm = [60.0, 90.0]', "rpm = [" + ", ".join(f"{30.0 + 5 * i}" for i in range(30)) + "]")


def test_kill_9_of_ked_plot_takes_its_figure_workers_along(tmp_path):
    out = tmp_path / "many.h5"
    run_campaign(parse_config(MANY), out, workers=1, progress=False)  # 60 quasi-static scenes
    figs = tmp_path / "figs"
    # no pipes: orphans holding them would block reading the output
    proc = _start(["plot", str(out), "--out", str(figs), "--workers", "2"], stdout=subprocess.DEVNULL,
                  stderr=subprocess.DEVNULL)
    workers = _workers_of(proc, 2)
    tracker = {c for c in _children(proc.pid) if "resource_tracker" in _cmdline(c)}
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(figs.glob("scene_*.png")):
        time.sleep(0.05)
    assert len(workers) == 2 and list(figs.glob("scene_*.png")), "the figure pool did not start drawing"
    proc.kill()
    proc.wait()
    # 60 figures on 2 workers take much longer than this bound; an orphan pool would still be drawing
    assert _gone(workers | tracker, limit_s=5), "figure workers outlived ked plot"
    n = len(list(figs.glob("scene_*.png")))
    time.sleep(1.0)
    assert len(list(figs.glob("scene_*.png"))) == n < 60


# -- a disk that fills during the run -------------------------------------------------------------------


FILLS = """
[campaign]
name = "fills"
step_deg = 10.0
n_modes = 1
solvers = ["quasi_static", "linear"]
[grid]
mass_models = ["tip", "extender"]
rpm = [30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0]
"""


@pytest.mark.parametrize("size", ["100k", "150k"])  # the disk fills early, late (the file ends at 125 kB)
def test_disk_filling_mid_run_ends_in_the_rescue_line_only(tmp_path, size, monkeypatch):
    # the rescue file goes beside the output, else into the temporary directory: this test's own
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    disk = tmp_path / "disk"
    disk.mkdir()
    _mount("-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(disk))
    try:
        cfg = tmp_path / "fills.toml"
        cfg.write_text(FILLS)
        res = ked("run", str(cfg), "--out", str(disk / "fills.h5"), "--workers", "1", "--no-progress",
                  "--no-figures", timeout=300)
        # before: the rescue line, then dozens of "Exception ignored" tracebacks and a segfault (exit 139)
        assert res.returncode == 1, (res.returncode, res.stderr[-2000:])
        err = res.stderr.strip().splitlines()
        assert "Traceback" not in res.stderr and "Exception ignored" not in res.stderr, res.stderr[-2000:]
        assert len(err) == 2 and err[0].startswith("campaign") and err[1].startswith("ked: "), err
        if "ked merge" in err[1]:  # scenes were computed before the disk filled: they are in the rescue file
            rescue = Path(err[1].split("are kept in ")[1].split(";")[0])
            assert rescue.exists() and store.verify(rescue) == []
        if (disk / "fills.h5").exists():
            assert store.verify(disk / "fills.h5") == []  # what was committed before stays intact
    finally:
        subprocess.run(["umount", str(disk)], check=False)


@pytest.mark.parametrize("free_kb", [30, 60, 120])  # the merged file needs about 150 kB
def test_merge_onto_a_filling_disk_leaves_dest_as_it_was(tmp_path, free_kb):
    # before: the rescue-style line, then "Exception ignored" tracebacks or a segfault inside HDF5's flush; a
    # stale temp file beside DEST and a run record added to DEST although no scene was
    src = tmp_path / "src.h5"
    run_campaign(parse_config(FILLS), src, workers=1, progress=False)
    disk = tmp_path / "disk"
    disk.mkdir()
    _mount("-t", "tmpfs", "-o", "size=400k", "tmpfs", str(disk))
    try:
        dest = disk / "dest.h5"
        run_campaign(parse_config(QS), dest, workers=1, progress=False)
        runs_before, scenes_before = store.file_info(dest)["n_runs"], len(store.stored_status(dest))
        free = os.statvfs(disk).f_bavail * os.statvfs(disk).f_frsize
        (disk / "fill").write_bytes(b"\0" * max(0, free - free_kb * 1024))
        res = ked("merge", str(src), str(dest), timeout=120)
        assert_one_line_error(res, str(dest))
        assert res.returncode == 1 and "Exception ignored" not in res.stderr
        assert sorted(p.name for p in disk.iterdir()) == ["dest.h5", "fill"]  # no temp file left behind
        assert store.verify(dest) == []
        assert (store.file_info(dest)["n_runs"], len(store.stored_status(dest))) == (runs_before, scenes_before)
    finally:
        subprocess.run(["umount", str(disk)], check=False)


# -- peers that are not a Dask scheduler ------------------------------------------------------------------


@pytest.fixture()
def http_server():
    """A plain HTTP server on loopback (it waits for a request line the Dask handshake never sends)."""
    import http.server
    import threading

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def test_scheduler_address_of_an_http_server_is_refused_within_the_limit(tmp_path, qs_config, http_server):
    # before: blocked in the Dask client's constructor for over 400 s, silently, holding the lock
    out = tmp_path / "s.h5"
    res = ked("run", str(qs_config), "--out", str(out), "--scheduler", http_server, "--no-progress", timeout=90)
    assert_one_line_error(res, http_server, "not a Dask scheduler", code=1)
    assert not out.exists()


def test_scheduler_probe_bounds_a_silent_peer():
    import socket

    from compare.runner import SchedulerError, probe_scheduler

    with socket.create_server(("127.0.0.1", 0)) as silent:  # accepts (the kernel does), never answers
        address = f"tcp://127.0.0.1:{silent.getsockname()[1]}"
        with pytest.raises(SchedulerError, match="not a Dask scheduler"):
            probe_scheduler(address, timeout_s=1.0)


# -- the Python API from a script without a main guard ----------------------------------------------------


def test_script_without_main_guard_fails_the_run_and_stores_nothing(tmp_path):
    script = tmp_path / "campaign.py"
    out = tmp_path / "noguard.h5"
    script.write_text(f"from compare.config import parse_config\nfrom compare.runner import run_campaign\n"
                      f"run_campaign(parse_config({QS!r}), {str(out)!r}, workers=2, progress=False)\n"
                      "print('finished')\n")
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    # before: six worker tracebacks, exit 0, and every scene stored as a "numerical" failure (WorkerCrashed)
    assert res.returncode != 0 and "finished" not in res.stdout
    assert res.stderr.count("Traceback") == 1, res.stderr  # the script's own, not one per worker
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("compare.executor.WorkerStartError") and 'if __name__ == "__main__":' in last, last
    assert not out.exists() or store.read_scenes(out) == []


# -- odd paths, odd values ---------------------------------------------------------------------------------


def test_fifo_or_symlink_loop_is_refused_in_one_line(tmp_path, qs_config, qs_results):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)  # opening it for reading would block until a writer comes: forever
    loop = tmp_path / "loop.h5"
    loop.symlink_to(tmp_path / "loop2.h5")
    (tmp_path / "loop2.h5").symlink_to(loop)
    for args in (["run", str(fifo), "--dry-run"], ["quasi", "--linkage", str(fifo)],
                 ["run", str(qs_config), "--out", str(fifo), "--no-progress"], ["inspect", str(fifo)],
                 ["plot", str(fifo)], ["merge", str(qs_results), str(fifo)]):
        assert_one_line_error(ked(*args, timeout=60), "pipe", "not a regular file", code=2)
    assert_one_line_error(ked("run", str(qs_config), "--out", str(loop), "--no-progress"), "loop.h5",
                          "symbolic links", code=2)


def test_malformed_study_readme_markers_are_named_in_one_line(tmp_path):
    from compare.sections import SectionError, write_section

    readme = tmp_path / "README.md"
    text = "# results\n<!-- BEGIN stability -->\nold text\n"  # its END marker was deleted by hand
    readme.write_text(text)
    res = ked("study", "stability", "--results-dir", str(tmp_path), "--report-only")
    assert_one_line_error(res, "README.md", "malformed section markers", code=1)
    with pytest.raises(SectionError, match="README.md"):
        write_section(readme, "stability", "new text")
    assert readme.read_text() == text


def test_a_users_own_readme_is_never_appended_to(tmp_path):
    # a README the harness did not make (no section markers) in --results-dir: refused before anything is
    # computed, in one line naming it; the file stays byte for byte
    from compare.sections import SectionError, write_section

    readme = tmp_path / "README.md"
    text = "# My project\n\nNotes I wrote myself.\n"
    readme.write_text(text)
    res = ked("study", "stability", "--results-dir", str(tmp_path), "--report-only")
    assert_one_line_error(res, "README.md", "not a results README the harness made", code=1)
    with pytest.raises(SectionError, match="README.md"):
        write_section(readme, "stability", "new text")
    assert readme.read_text() == text and sorted(p.name for p in tmp_path.iterdir()) == ["README.md"]


def test_inspect_json_is_strict_json_where_a_value_is_nan(tmp_path, qs_results):
    import json

    import h5py

    out = tmp_path / "nan.h5"
    out.write_bytes(qs_results.read_bytes())
    from compare import tables

    with h5py.File(out, "a") as f:  # a solver statistic that is not a number (as json.dumps stores it)
        key = sorted(f["scenes"])[0]
        cols, kinds = tables.read_table(f["solution_table"]), tables.kinds_of(f["solution_table"])
        cols["stats_json"][(cols["key"] == key) & (cols["solver"] == "quasi_static")] = '{"residual": NaN}'
        tables.write_table(f, "solution_table", cols, kinds=kinds)
    res = ked("inspect", str(out), key, "--json")
    assert res.returncode == 0, res.stderr

    def refuse(constant: str) -> None:
        raise ValueError(f"not strict JSON: {constant}")

    detail = json.loads(res.stdout, parse_constant=refuse)
    assert detail["solutions"]["quasi_static"]["stats"]["residual"] is None


def test_working_directory_deleted_mid_run_still_summarises_every_scene(tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    (tmp_path / "c.toml").write_text(FILLS)
    out = tmp_path / "r.h5"
    proc = _start(["run", "../c.toml", "--out", "../r.h5", "--workers", "1", "--no-progress", "--no-figures"],
                  cwd=work)
    _workers_of(proc, 1, until=out)
    time.sleep(0.5)
    work.rmdir()
    stdout, err = _finish(proc, limit_s=300)
    assert proc.returncode == 0, err
    n = len(store.read_scenes(out))
    assert n == 16 and "16 ok" in stdout, stdout[-600:]  # was: "0 scenes" though all were stored


@pytest.mark.parametrize("limit_kb", [100_000, 300_000, 400_000])
def test_too_low_memory_limit_is_one_line(tmp_path, qs_config, limit_kb):
    # ulimit -v: at 100 MB OpenBLAS aborted with its own message, at 300 MB the import failed (ImportError, or
    # inside HDF5's initialization, which printed its diagnostics first), at 400 MB a worker could not start
    # and the run waited for ever (ked_cli.errors.MIN_ADDRESS_SPACE)
    import resource

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit_kb * 1024, resource.RLIM_INFINITY))

    res = subprocess.run([*KED, "run", str(qs_config), "--out", str(tmp_path / "m.h5"), "--no-progress",
                          "--no-figures"], capture_output=True, text=True, timeout=120, preexec_fn=limit)
    assert_one_line_error(res, "memory", "ulimit -v", code=1)


def test_a_failed_commit_adds_no_run_record(tmp_path, monkeypatch):
    # the first commit of a run fails (injected: the disk fails as the scenes are written): the run's record
    # must not be in the file either (it is written with the run's first scenes, in one transaction), and the
    # scenes computed go to the rescue file
    out = tmp_path / "r.h5"
    run_campaign(parse_config(QS), out, workers=1, progress=False)
    runs_before, before = store.file_info(out)["n_runs"], out.read_bytes()

    from compare import writer

    real, calls = writer._commit, []

    def disk_fails_once(*args, **kwargs):  # the run's first commit fails; the rescue file's is written
        calls.append(1)
        if len(calls) == 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(*args, **kwargs)

    monkeypatch.setattr(writer, "_commit", disk_fails_once)
    more = QS.replace("rpm = [", "rpm = [135.0, ")
    with pytest.raises(store.CommitError, match="rescue"):
        run_campaign(parse_config(more), out, workers=1, progress=False)
    monkeypatch.undo()
    assert store.file_info(out)["n_runs"] == runs_before and out.read_bytes() == before
    assert [p for p in tmp_path.iterdir() if ".rescue-" in p.name]


def _stored_campaign(tmp_path: Path) -> tuple[Path, Path, str]:
    """(config, results file, key of its first scene) of the quasi-static campaign QS run by `ked run`."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(QS)
    out = tmp_path / "r.h5"
    assert ked("run", str(cfg), "--out", str(out), "--no-progress", "--no-figures").returncode == 0
    return cfg, out, sorted(r.key for r in store.read_scenes(out))[0]


def test_retry_failed_repairs_a_scene_whose_history_was_deleted(tmp_path):
    # a stored ok scene loses its solution datasets (damage): `--retry-failed` must compute it again, whole,
    # so that the file verifies afterwards (before: "1 ok" and the file still INVALID)
    import h5py

    cfg, out, key = _stored_campaign(tmp_path)
    with h5py.File(out, "r+") as f:
        del f["scenes"][key]["solutions"]["quasi_static"]
    assert store.verify(out)  # damaged
    res = ked("run", str(cfg), "--out", str(out), "--no-progress", "--no-figures", "--retry-failed")
    assert res.returncode == 0, res.stderr
    assert store.verify(out) == []
    (scene,) = [r for r in store.read_scenes(out) if r.key == key]
    assert scene.solutions["quasi_static"].ok and scene.solutions["quasi_static"].deflection


def test_an_output_directory_deleted_mid_run_is_not_made_again(tmp_path, monkeypatch):
    # the user deletes the output directory while the run writes into it: the next commit must not make it
    # again with a file no command can read (no schema attributes, no run record); the scenes computed go to
    # a rescue file elsewhere that verifies
    import shutil

    work = tmp_path / "work"
    spare = tmp_path / "spare"
    spare.mkdir()
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(spare))  # where the rescue file goes (beside out is gone)
    seen: list[str] = []

    def delete_after_first(r) -> None:
        seen.append(r.key)
        if len(seen) == 1:
            shutil.rmtree(work)

    with pytest.raises(store.CommitError) as err:
        run_campaign(parse_config(FILLS), work / "r.h5", workers=1, progress=False, on_result=delete_after_first)
    assert not work.exists()
    rescued = [p for p in spare.iterdir() if ".rescue-" in p.name]
    assert len(rescued) == 1 and str(rescued[0]) in str(err.value) and store.verify(rescued[0]) == []


def test_plot_names_a_scene_whose_history_was_cut(tmp_path):
    # a history cut from 36 rows to 5 (damage): `ked plot` draws the intact scenes and names the damaged
    # one in one line with the file, exit 1 (before: "internal error" naming nothing)
    import h5py

    cfg, out, key = _stored_campaign(tmp_path)
    with h5py.File(out, "r+") as f:
        sol = f["scenes"][key]["solutions"]
        old = sol["quasi_static"]
        cut, attrs = old[:5], {k: v for k, v in old.attrs.items() if k != "DIMENSION_LIST"}
        del sol["quasi_static"]
        sol.create_dataset("quasi_static", data=cut).attrs.update(attrs)
    res = ked("plot", str(out), "--no-progress")
    assert res.returncode == 1 and "Traceback" not in res.stderr and "internal error" not in res.stderr, res.stderr
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and str(out) in err[0] and key in err[0] and "damaged" in err[0], err
    assert len(list((tmp_path / "r_figures").glob("scene_*.png"))) == 3  # the three intact scenes
