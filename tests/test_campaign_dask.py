"""A real local Dask distributed cluster runs a small campaign with results identical to the local
process pool (same scenes, same keys, bit-identical histories and metrics; only run stats differ)."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from compare import store
from compare.config import parse_config
from compare.runner import run_campaign
from ked_cli.main import cli as main

from .conftest import QUICK_DYNAMIC

CONFIG = """
[campaign]
name = "dask"
step_deg = 30.0
n_modes = 2
[grid]
mechanisms = ["source", "cognate"]
mass_models = ["extender"]
rpm = [60.0, 120.0]
""" + QUICK_DYNAMIC


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as c:
        yield c


def test_dask_cluster_matches_process_pool(tmp_path, cluster):
    cfg = parse_config(CONFIG)
    local = tmp_path / "local.h5"
    dask = tmp_path / "dask.h5"
    run_campaign(cfg, local, workers=2, progress=False)
    summary = run_campaign(cfg, dask, scheduler=cluster.scheduler_address, progress=False)
    assert summary.ok == 4
    assert store.verify(dask) == []
    a = {r.key: r for r in store.read_scenes(local)}
    b = {r.key: r for r in store.read_scenes(dask)}
    assert a.keys() == b.keys() and len(a) == 4
    for k in a:
        ra, rb = a[k], b[k]
        assert ra.status == rb.status == "ok"
        assert ra.rpm == rb.rpm and ra.omega1_min == rb.omega1_min
        for name in ("crank_angle", "coupler_point", "natural_frequencies"):
            np.testing.assert_array_equal(getattr(ra, name), getattr(rb, name))
        for side in ("quasi_static", "dynamic"):
            for c in ra.spec.outputs:
                np.testing.assert_array_equal(getattr(ra, side)[c], getattr(rb, side)[c])
        assert ra.metrics == rb.metrics
        assert ra.stat("dynamic", "steps") == rb.stat("dynamic", "steps")
        assert ra.stat("dynamic", "cycles") == rb.stat("dynamic", "cycles")
    # and through the CLI: everything is already stored, so the cluster is asked for nothing
    cfg_file = tmp_path / "dask.toml"
    cfg_file.write_text(CONFIG)
    res = CliRunner().invoke(main, ["run", str(cfg_file), "--out", str(dask), "--scheduler",
                                    cluster.scheduler_address, "--no-progress", "--no-figures"])
    assert res.exit_code == 0 and "4 skipped" in res.output


def test_dask_cli_runs_new_scenes(tmp_path, cluster):
    cfg_file = tmp_path / "dask.toml"
    cfg_file.write_text(CONFIG.replace("rpm = [60.0, 120.0]", "rpm = [90.0]").replace('"cognate"', ""))
    out = tmp_path / "cli.h5"
    res = CliRunner().invoke(main, ["run", str(cfg_file), "--out", str(out), "--scheduler",
                                    cluster.scheduler_address, "--no-progress", "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "1 ok, 0 failed" in res.output
    assert store.verify(out) == []
