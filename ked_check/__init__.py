"""ked_check: the design check of one linkage (``ked check``): which tier of model its elastic answer needs at
each speed, how sure that call is, its critical speeds, and its link stresses and fatigue.

One call, :func:`run` (``ked_check.report.run``): a linkage and speeds in, a :class:`CheckReport` out (one row per
speed, the critical speeds and amplification peaks); the CLI only renders it.  The rows alone:
``ked_check.check.check`` (the function of the submodule ``ked_check.check``).  The rule of the quasi-static
call (:mod:`ked_check.verdict_rule`) reads the check's own published limits, package data of this package
(:mod:`ked_check.published`, written by ``ked study atlas``).  Names are imported on first use: ``ked check``
keeps its start-up cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

_API = {"run": "ked_check.report", "CheckReport": "ked_check.report", "CheckRow": "ked_check.check",
        "spec_for": "ked_check.check", "VerdictMargins": "ked_check.verdict_rule",
        "check_critical": "ked_check.critical"}
__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'ked_check' has no attribute {name!r}")
