"""Figures for reports: fixed solver colours, the amplification figure's legend and error scale, file
format and resolution, one figure directory per results file, and figures and index written whole even
when the disk fills (a real small campaign of the quasi-static and linear solvers, real matplotlib)."""

from __future__ import annotations

import dataclasses
import errno
import json
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.colors as mcolors
import pytest
from matplotlib.figure import Figure

from compare import figure_dir, plots, store
from compare import solvers as registry
from compare.config import parse_config
from compare.runner import run_campaign

CONFIG = """
[campaign]
name = "figure-output"
step_deg = 30.0
solvers = ["quasi_static", "linear"]
[grid]
mass_models = ["tip", "extender"]
rpm = [60.0, 150.0, 300.0]
"""


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("figout") / "campaign.h5"
    run_campaign(parse_config(CONFIG), out, workers=1, progress=False)
    return out


@pytest.fixture(scope="module")
def results(campaign):
    return list(store.read_scenes(campaign))


def _history_lines(fig):
    return {ln.get_label(): ln for ln in fig.axes[0].get_lines()}


def _line_of(fig, name):
    return next(ln for lb, ln in _history_lines(fig).items() if lb.startswith(registry.label(name)))


def test_a_solver_keeps_its_colour_when_another_turns_grey(results):
    # the same scene drawn twice: as stored (every answer valid) and with the quasi-static answer marked
    # outside its model's range; the linear answer's colour is the fixed one of its solver both times
    r = next(r for r in results if r.spec.mass_model.name == "extender" and r.rpm == 60.0)
    assert all(s.ok and not s.flags for s in r.solutions.values())  # the premise: Case III at 60 rpm
    flagged = dataclasses.replace(r, solutions=r.solutions | {
        "quasi_static": dataclasses.replace(r.solutions["quasi_static"], flags=("large_deflection",))})
    for shown in (r, flagged):
        fig = plots.scene_figure(shown)
        assert mcolors.same_color(_line_of(fig, "linear").get_color(), plots.SOLVER_COLORS["linear"])
    assert mcolors.same_color(_line_of(plots.scene_figure(flagged), "quasi_static").get_color(), plots.INVALID_COLOR)
    assert mcolors.same_color(_line_of(plots.scene_figure(r), "quasi_static").get_color(),
                              plots.SOLVER_COLORS["quasi_static"])
    assert len(set(plots.SOLVER_COLORS.values())) == len(plots.SOLVER_COLORS)  # one colour, one solver
    assert set(registry.names()) <= set(plots.SOLVER_COLORS)
    assert plots.solver_color("someone_elses") == plots.solver_color("someone_elses")  # stable for extras


def test_amplification_legend_is_below_the_panels_and_covers_no_title(results):
    fig = plots.amplification_figure(results)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()  # the real layout (constrained)
    renderer = canvas.get_renderer()
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    width = fig.bbox.width
    for ax in fig.axes[:2]:
        title = ax.title.get_window_extent(renderer)
        assert not box.overlaps(title)
        assert box.y1 <= ax.get_window_extent(renderer).y0  # below the panel
        assert ax.get_window_extent(renderer).width > 0.35 * width  # each panel keeps its width


def test_error_scale_is_logarithmic_over_more_than_a_decade(results):
    assert plots.error_scale([150.0, 80.0, 20.0], 0.10) == "log"  # 10 % among 150 %
    assert plots.error_scale([2.0, 5.0, 9.0], 0.10) == "linear"  # within one decade
    assert plots.error_scale([], 0.10) == "linear"
    errors = [100 * r.verdict.verdict_error for r in results]
    assert max(errors) > 5 * 10.0 and max(errors) > 10 * min(errors)  # the premise: Case I at 300 rpm ~100 %
    ax_e = plots.amplification_figure(results).axes[1]
    assert ax_e.get_yscale() == "log"
    assert any(ln.get_label() == "tolerance 10%" and ln.get_ydata()[0] == 10.0 for ln in ax_e.get_lines())


def _png_size(path):
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def test_ked_plot_format_and_dpi(campaign, tmp_path):
    from ked_cli.campaign import FIGURE_FORMATS, plot_cmd

    assert FIGURE_FORMATS == figure_dir.FORMATS
    svg, png = tmp_path / "svg", tmp_path / "png"
    plot_cmd.main([str(campaign), "--out", str(svg), "--format", "svg", "--workers", "1"], standalone_mode=False)
    text = (svg / "amplification.svg").read_text()
    assert text.lstrip().startswith("<?xml") and "<svg" in text
    index = json.loads((svg / "index.json").read_text())
    assert all(name.endswith(".svg") for name in index if name != figure_dir.MANIFEST)
    plot_cmd.main([str(campaign), "--out", str(png), "--dpi", "50", "--workers", "1"], standalone_mode=False)
    # the figure's size in inches times the resolution (the amplification figure is 12 x 5.5 in)
    assert _png_size(png / "amplification.png") == (600, 275)


def test_a_second_results_file_does_not_overwrite_the_first_ones_figures(campaign, tmp_path):
    import click

    from ked_cli.campaign import plot_cmd

    figs = tmp_path / "shared"
    plot_cmd.main([str(campaign), "--out", str(figs), "--workers", "1"], standalone_mode=False)
    before = {p.name: p.read_bytes() for p in figs.iterdir()}
    other = tmp_path / "other.h5"
    shutil.copy(campaign, other)
    with pytest.raises(click.ClickException) as exc:
        plot_cmd.main([str(other), "--out", str(figs), "--workers", "1"], standalone_mode=False)
    assert str(campaign.resolve()) in exc.value.message and "another results file" in exc.value.message
    assert {p.name: p.read_bytes() for p in figs.iterdir()} == before  # nothing touched
    index = json.loads((figs / "index.json").read_text())
    assert index[figure_dir.MANIFEST]["results_file"] == str(campaign.resolve())
    plot_cmd.main([str(campaign), "--out", str(figs), "--workers", "1"], standalone_mode=False)  # its own: fine


def test_a_full_disk_names_the_file_and_the_index_lists_only_figures_written(results, tmp_path, monkeypatch):
    # an OS failure injected into matplotlib's writer: the third figure finds the disk full
    real = Figure.savefig
    calls = []

    def savefig(self, fname, *a, **kw):
        calls.append(fname)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, "No space left on device", str(fname))
        return real(self, fname, *a, **kw)

    monkeypatch.setattr(Figure, "savefig", savefig)
    out = tmp_path / "figs"
    with pytest.raises(OSError) as exc:
        figure_dir.write_figures(results, out, workers=1, source="campaign.h5")
    names = figure_dir.figure_names(results)
    third = out / names[results[2].key]
    assert exc.value.errno == errno.ENOSPC and exc.value.filename == str(third)
    from ked_cli.errors import os_message

    assert os_message(exc.value).startswith(f"{third}: No space left on device (the disk is full")
    index = json.loads((out / "index.json").read_text())
    listed = {k for k in index if k != figure_dir.MANIFEST}
    assert listed == {names[r.key] for r in results[:2]}  # the two written, not the one that failed
    assert all((out / f).is_file() for f in listed | set(index[figure_dir.MANIFEST]["files"]))
    assert not third.exists() and not list(out.glob("*.tmp"))  # no partial figure, no temporary file left
    monkeypatch.setattr(Figure, "savefig", real)  # space again: the next run completes the directory
    figure_dir.write_figures(results, out, workers=1, source="campaign.h5")
    index = json.loads((out / "index.json").read_text())
    assert {k for k in index if k != figure_dir.MANIFEST} == set(names.values())


def test_ked_plot_into_an_impossible_directory_says_which_file_in_one_line(campaign, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("mine")
    proc = subprocess.run([sys.executable, "-m", "ked_cli", "plot", str(campaign), "--out", str(blocker / "figs")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(blocker) in lines[0], proc.stderr
    assert blocker.read_text() == "mine"


class _Terminal:
    def __init__(self, tty):
        self.tty, self.parts = tty, []

    def isatty(self):
        return self.tty

    def write(self, text):
        self.parts.append(text)
        return len(text)

    def flush(self):
        return None


@pytest.mark.parametrize("tty", [True, False])
def test_ked_plot_shows_the_progress_bar_only_on_a_terminal(campaign, tmp_path, monkeypatch, tty):
    from compare import progress
    from ked_cli.campaign import plot_cmd

    err = _Terminal(tty)
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(progress, "DELAY_S", 0.0)  # at once (the real delay: 2 s)
    plot_cmd.main([str(campaign), "--out", str(tmp_path / "f"), "--workers", "1"], standalone_mode=False)
    text = "".join(err.parts)
    assert ("figures" in text and "figure" in text and "/7" in text) if tty else text == ""


def test_ked_run_writes_figures_in_the_format_asked(tmp_path):
    from ked_cli.campaign import run_cmd

    cfg = tmp_path / "tiny.toml"
    cfg.write_text(CONFIG.replace('rpm = [60.0, 150.0, 300.0]', 'rpm = [60.0]').replace(
        'mass_models = ["tip", "extender"]', 'mass_models = ["extender"]'))
    out = tmp_path / "tiny.h5"
    run_cmd.main([str(cfg), "--out", str(out), "--workers", "1", "--no-progress", "--figure-format", "pdf"],
                 standalone_mode=False)
    figs = tmp_path / "tiny_figures"
    assert (figs / "amplification.pdf").read_bytes().startswith(b"%PDF")
    assert [p.suffix for p in figs.glob("scene_*")] == [".pdf"]
    assert json.loads((figs / "index.json").read_text())[figure_dir.MANIFEST]["results_file"] == str(out.resolve())


def test_a_shown_bar_appears_and_ticks_while_one_long_step_runs(monkeypatch):
    # one step that takes long (an Exudyn run of `ked check --confirm`): the bar is drawn once its delay
    # has passed, without waiting for the step to end (polled with a generous limit, no fixed sleep)
    import time

    from compare import progress

    err = _Terminal(True)
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(progress, "TICK_S", 0.02)
    with progress.progress_bar(1, "one long step", delay=0.0):
        deadline = time.monotonic() + 60.0
        while "one long step" not in "".join(err.parts) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert "one long step" in "".join(err.parts) and "0/1" in "".join(err.parts)


def test_a_results_file_moved_with_its_figures_still_owns_them(campaign, tmp_path):
    from ked_cli.campaign import plot_cmd

    home = tmp_path / "project"
    home.mkdir()
    shutil.copy(campaign, home / "campaign.h5")
    plot_cmd.main([str(home / "campaign.h5"), "--workers", "1"], standalone_mode=False)
    moved = tmp_path / "moved"
    shutil.move(home, moved)  # the user moves the project directory
    plot_cmd.main([str(moved / "campaign.h5"), "--workers", "1"], standalone_mode=False)  # not refused
    index = json.loads((moved / "campaign_figures" / "index.json").read_text())
    assert index[figure_dir.MANIFEST]["results_file"] == str((moved / "campaign.h5").resolve())


def test_figures_drawn_on_the_executor_report_a_failed_figure_by_its_file(tmp_path):
    # more scenes than twice the workers: the figures are drawn on the one executor's worker processes; a figure
    # that cannot be written (its temporary file's place taken by a directory: an OS error in the worker) stops
    # the drawing with that figure's FigureWriteError, naming it; the index lists only figures that are there,
    # and once the place is free the next run completes the directory
    from compare import read_scenes

    results = read_scenes(Path(__file__).resolve().parents[1] / "results" / "reference" / "reference.h5")
    assert len(results) > 4
    out = tmp_path / "figs"
    names = figure_dir.figure_names(results)
    victim = out / names[results[-1].key]
    out.mkdir()
    (out / (victim.name + ".tmp")).mkdir()
    with pytest.raises(figure_dir.FigureWriteError) as exc:
        figure_dir.write_figures(results, out, workers=2, source="reference.h5")
    assert exc.value.filename == str(victim) and not victim.exists()
    index = json.loads((out / "index.json").read_text())
    assert all((out / k).is_file() for k in index if k != figure_dir.MANIFEST)
    (out / (victim.name + ".tmp")).rmdir()
    written = figure_dir.write_figures(results, out, workers=2, source="reference.h5")
    assert victim in written and all((out / n).is_file() for n in names.values())
