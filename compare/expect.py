"""Expectations on agreement: what a campaign's verdicts must be (the ``[expect]`` table of a campaign config).

::

    [expect]
    holds_below_speed_ratio = 0.08            # the quasi-static answer holds in every scene with r < 0.08
    verdict_error_below = { tip = 0.05 }      # mass model (or "all") -> bound of the verdict error [1]
    holds = ["source/extender/300rpm/..."]    # these scenes hold (scene labels or key prefixes)
    fails = ["source/tip/300rpm/..."]         # these scenes do not hold

The verdict and its error are the campaign's (:attr:`compare.results.SceneResult.verdict`: the quasi-static
history error of the deflection vector against the scene's reference solver).  A scene that failed, or that has
no verdict, violates every expectation that concerns it.  Checked by ``ked run`` at the end, by
``ked inspect FILE --expect`` and by ``ked diff``; a violation names the scene, the quantity, the value and the
bound.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from compare.results import SceneResult

KEYS = ("holds_below_speed_ratio", "verdict_error_below", "holds", "fails")
ALL = "all"


@dataclass(frozen=True)
class Expectations:
    """``holds_below_speed_ratio`` [1] (None: none), ``verdict_error_below``: (mass model or "all", bound [1])
    pairs, ``holds`` / ``fails``: scene labels or key prefixes."""

    holds_below_speed_ratio: float | None = None
    verdict_error_below: tuple[tuple[str, float], ...] = ()
    holds: tuple[str, ...] = ()
    fails: tuple[str, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.holds_below_speed_ratio is not None or self.verdict_error_below or self.holds
                    or self.fails)

    def to_dict(self) -> dict[str, Any]:
        return {"holds_below_speed_ratio": self.holds_below_speed_ratio,
                "verdict_error_below": dict(self.verdict_error_below), "holds": list(self.holds),
                "fails": list(self.fails)}


@dataclass(frozen=True)
class Violation:
    """One violated expectation: the scene (label, key), the quantity, its value and the bound."""

    scene: str
    key: str
    quantity: str
    value: Any
    bound: str

    @property
    def message(self) -> str:
        v = f"{self.value:.4g}" if isinstance(self.value, float) else str(self.value)
        return f"{self.scene}: {self.quantity} = {v}, expected {self.bound}"

    def to_dict(self) -> dict[str, Any]:
        v = self.value if not isinstance(self.value, float) or math.isfinite(self.value) else str(self.value)
        return {"scene": self.scene, "key": self.key, "quantity": self.quantity, "value": v, "bound": self.bound,
                "message": self.message}


def _positive(v: Any, path: str, problems: list[str]) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        problems.append(f"{path}: must be a finite number > 0, got {v!r}")
        return None
    return float(v)


def parse_expect(table: Any, mass_models: Sequence[str], path: str = "expect") -> tuple[Expectations, list[str]]:
    """An ``[expect]`` TOML table -> (:class:`Expectations`, problems as ``"toml.path: message"``);
    ``mass_models``: the names a ``verdict_error_below`` key may take (besides "all")."""
    problems: list[str] = []
    if not isinstance(table, dict):
        return Expectations(), [f"{path}: must be a table, got {type(table).__name__}"]
    problems += [f"{path}.{k}: unknown key (allowed: {', '.join(KEYS)})" for k in table if k not in KEYS]
    r = None
    if "holds_below_speed_ratio" in table:
        r = _positive(table["holds_below_speed_ratio"], f"{path}.holds_below_speed_ratio", problems)
    below: list[tuple[str, float]] = []
    raw = table.get("verdict_error_below", {})
    if not isinstance(raw, dict):
        problems.append(f"{path}.verdict_error_below: must be a table of mass model (or \"all\") -> bound")
    else:
        for mm, v in raw.items():
            p = f"{path}.verdict_error_below.{mm}"
            if mm != ALL and mm not in mass_models:
                problems.append(f"{p}: unknown mass model (allowed: {', '.join((ALL, *mass_models))})")
                continue
            b = _positive(v, p, problems)
            if b is not None:
                below.append((mm, b))
    names: dict[str, tuple[str, ...]] = {}
    for k in ("holds", "fails"):
        v = table.get(k, [])
        if not isinstance(v, list) or not all(isinstance(x, str) and x.strip() for x in v):
            problems.append(f"{path}.{k}: must be an array of scene labels or key prefixes (non-empty strings)")
            v = []
        names[k] = tuple(v)
    both = set(names["holds"]) & set(names["fails"])
    if both:
        problems.append(f"{path}: {sorted(both)[0]!r} is expected both to hold and to fail")
    return Expectations(r, tuple(below), names["holds"], names["fails"]), problems


def _find(results: Sequence[SceneResult], ident: str) -> list[SceneResult]:
    exact = [r for r in results if r.spec.label == ident or r.key == ident]
    return exact or [r for r in results if r.key.startswith(ident)]


def _verdict(r: SceneResult) -> tuple[float, bool] | None:
    v = r.verdict if r.ok else None
    if v is None or not math.isfinite(v.verdict_error):
        return None
    return v.verdict_error, v.holds


def _no_verdict(r: SceneResult) -> str:
    return f"failed ({r.failure_class or r.stage})" if not r.ok else "no verdict"


def check_expectations(results: Sequence[SceneResult], exp: Expectations) -> list[Violation]:
    """Every violated expectation of ``exp`` over ``results`` (empty: all met)."""
    out: list[Violation] = []
    if exp.holds_below_speed_ratio is not None:
        bound = exp.holds_below_speed_ratio
        for r in results:
            v = r.verdict if r.ok else None
            ratio = v.speed_ratio if v is not None else r.spec.speed.value if r.spec.speed.kind == "ratio" else None
            if ratio is None and r.ok is False and math.isfinite(r.omega1_min) and r.omega1_min > 0:
                ratio = r.rpm * math.pi / 30 / r.omega1_min
            if ratio is None or not ratio < bound:
                continue
            got = _verdict(r)
            if got is None:
                out.append(Violation(r.spec.label, r.key, "verdict", _no_verdict(r),
                                     f"holds (r = {ratio:.3g} < {bound:g})"))
            elif not got[1]:
                out.append(Violation(r.spec.label, r.key, "verdict_error", got[0],
                                     f"< tolerance {r.spec.tolerance:g} (holds: r = {ratio:.3g} < {bound:g})"))
    for mm, bound in exp.verdict_error_below:
        for r in results:
            if mm != ALL and r.spec.mass_model.name != mm:
                continue
            got = _verdict(r)
            if got is None:
                out.append(Violation(r.spec.label, r.key, "verdict_error", _no_verdict(r), f"< {bound:g}"))
            elif not got[0] < bound:
                out.append(Violation(r.spec.label, r.key, "verdict_error", got[0], f"< {bound:g} ({mm})"))
    for want, idents in ((True, exp.holds), (False, exp.fails)):
        for ident in idents:
            found = _find(results, ident)
            if not found:
                out.append(Violation(ident, "", "verdict", "scene not in the file", "holds" if want else "fails"))
            for r in found:
                got = _verdict(r)
                if got is None or got[1] != want:
                    value = _no_verdict(r) if got is None else ("holds" if got[1] else "fails")
                    out.append(Violation(r.spec.label, r.key, "verdict", value,
                                         ("holds" if want else "fails") + ("" if got is None else
                                                                           f" (verdict_error {got[0]:.4g})")))
    return out
