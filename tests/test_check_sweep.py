"""ked check's progress bar: over the critical-speed sweep, and never for a check shorter than its delay."""

from __future__ import annotations

import sys


class Terminal:
    """stderr of a terminal, recording what is written."""

    def __init__(self):
        self.parts = []

    def isatty(self):
        return True

    def write(self, text):
        self.parts.append(text)
        return len(text)

    def flush(self):
        return None


def test_the_progress_bar_covers_the_critical_speed_sweep(monkeypatch):
    # `ked check --rpm-range` on a terminal: one bar over the speeds and then the sweep's Floquet
    # evaluations (here shown at once: delay 0), which it names; it ends complete (n = total)
    from ked_check import check as chk
    from ked_check import report
    from ked_cli.check import check as command

    bars = []
    original = report.progress

    def recording(total):
        bar = original(total)
        bars.append(bar)
        return bar

    err = Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(chk, "PROGRESS_DELAY_S", 0.0)
    monkeypatch.setattr(report, "progress", recording)  # the bar of the check's one call
    command.main(["--mass-model", "tip", "--rpm-range", "100:200:3"], standalone_mode=False)
    text = "".join(err.parts)
    assert "critical speeds" in text and "ked check" in text
    (bar,) = bars
    assert bar.n == bar.total >= 3 + 2 * 3  # the speeds, then at least the fine sweep's evaluations


def test_a_check_shorter_than_the_delay_draws_no_bar(monkeypatch):
    # the bar is for checks that run long: before its delay nothing is drawn, not even the stage names
    # (tqdm draws a bar at once on a refresh, which a stage name asks for)
    from ked_check import check as chk
    from ked_cli.check import check as command

    err = Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(chk, "PROGRESS_DELAY_S", 1e6)  # a check "shorter than the delay", however slow
    command.main(["--mass-model", "tip", "--rpm-range", "100:200:3"], standalone_mode=False)
    assert "".join(err.parts) == ""
