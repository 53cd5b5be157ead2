"""The design check as one call: :func:`run` checks a linkage at its speeds and, with three speeds or more, finds
its critical speeds and amplification peaks, on one pool of workers and under one progress bar; the command
line only renders the :class:`CheckReport`."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from ked_check.check import CheckRow, check, progress, redraw
from ked_check.checkwork import CheckWorkers

SWEEP_FROM = 3
"""Speeds from which the check looks for critical speeds (local maxima over the speeds checked)."""


@dataclass(frozen=True)
class CheckReport:
    """One design check: its rows (one per speed, :class:`ked_check.check.CheckRow`), the critical speeds
    (:class:`ked_check.critical.CriticalSpeed`: of weakest damping, local maxima of max |Floquet multiplier|) and
    the amplification peaks [rev/min] (local maxima of the linear / quasi-static peak); both empty below
    :data:`SWEEP_FROM` speeds."""

    rows: tuple[CheckRow, ...]
    critical_speeds: tuple[Any, ...] = ()
    amplification_peaks_rpm: tuple[float, ...] = ()


def run(source: Any, mechanism: str, mass_model: Any, rpms: Sequence[float], *, workers: int = 1,
        specs: Sequence[Any] | None = None, **options: Any) -> CheckReport:
    """The design check of ``source`` at ``rpms`` [rev/min] (the arguments and ``options`` of
    :func:`ked_check.check.check`: stiffness_scale, damping_ratio, direction, tolerance, confirm, material), then
    with :data:`SWEEP_FROM` speeds or more its critical speeds (:func:`ked_check.critical.check_critical`), on
    ``workers`` processes once the work is worth them (:class:`ked_check.checkwork.CheckWorkers`).  ValueError
    for bad input; :class:`ked_check.checkwork.CheckWorkerError` when a worker fails."""
    with progress(len(rpms)) as bar, CheckWorkers(workers) as pool:
        rows = check(source, mechanism, mass_model, rpms, bar=bar, workers=pool, specs=specs, **options)
        if len(rpms) < SWEEP_FROM:
            return CheckReport(tuple(rows))
        from ked_check.critical import check_critical, sweep_evaluations

        bar.total = bar.n + sweep_evaluations(rows)
        redraw(bar)
        sweep = {k: v for k, v in options.items() if k in ("stiffness_scale", "damping_ratio", "direction",
                                                            "tolerance")}
        crit, amp, rows = check_critical(rows, source, mechanism, mass_model, bar=bar, workers=pool,
                                         base=specs[0] if specs else None, **sweep)
    return CheckReport(tuple(rows), tuple(crit), tuple(amp))
