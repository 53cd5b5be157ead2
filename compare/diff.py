"""Regression comparison of two results files, scene by scene (``ked diff BASELINE NEW``, the pytest plugin).

Scenes are matched by content key; the scenes left are matched by the physical scene (linkage, mechanism, mass
model, speed, stiffness scale, damping ratio, direction), and the settings that differ are named.  Per matched
scene and solver the checks are (tolerances: :mod:`compare.tolerances`, tier ``same`` for a solver whose
settings and versions are unchanged, ``physics`` otherwise):

- ``status``: ok in BASELINE and failed in NEW (the scene, or one solver) fails; failed -> ok is reported, passes;
- ``finite``: a NaN or inf in a stored history of NEW always fails;
- ``history``: each stored history's drift, max |new - base| / max |base|, within the tier's ``history`` (or
  under the absolute floor ``history_abs``); a link's stresses (quantity ``stress_<link>``, both fibres) too,
  their floor ``history_abs`` taken relative to the peak;
- ``verdict``: a verdict flip (``holds`` of any pair of solvers, and the stress verdict of a pair with link
  stresses, quantity ``<pair>/stress``) always fails;
- ``verdict_error``: |new - base| of each pair's verdict error within the tier's ``verdict_error`` (the larger of
  the solver's and its reference's: the error moves with either);
- ``missing`` / ``added``: a scene of BASELINE without a match in NEW, a scene of NEW without one in BASELINE.

Everything here is computed from :func:`compare.store.read_scenes` (one reader of results files).
"""

from __future__ import annotations

import dataclasses
import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from compare.expect import Expectations, Violation, check_expectations
from compare.metrics import is_stress
from compare.physical import SCENE_SETTINGS, spec_physical_key, spec_settings
from compare.results import SceneResult
from compare.solvers import STRESS, STRESS_PREFIX
from compare.tolerances import Tolerances

VERSION_KEYS = {"harness_version": None, "exudyn_version": "dynamic"}
"""File attribute -> the solver whose tier a change of it moves (None: every solver)."""
CHECKS = ("missing", "added", "status", "finite", "verdict", "verdict_error", "history")


@dataclass(frozen=True)
class Check:
    """One check of one scene: ``check`` (one of :data:`CHECKS`), ``solver``, ``quantity`` (a component, a pair or
    a status), ``value`` and ``bound`` (numbers [1] for drifts, text otherwise), ``tier``, and the ``message``."""

    scene: str
    key: str
    check: str
    solver: str
    quantity: str
    value: Any
    bound: Any
    passed: bool
    tier: str = ""
    message: str = ""

    @property
    def severity(self) -> float:
        """How far beyond its bound a failed check is (inf for a flip, a status change, a missing scene)."""
        if self.passed:
            return 0.0
        if isinstance(self.value, float) and isinstance(self.bound, float) and self.bound > 0 \
                and math.isfinite(self.value):
            return self.value / self.bound
        return math.inf

    @property
    def name(self) -> str:
        """``check solver/quantity`` (e.g. ``history dynamic/dx``)."""
        what = "/".join(x for x in (self.solver, self.quantity) if x)
        return f"{self.check} {what}" if what else self.check

    def to_dict(self) -> dict[str, Any]:
        return {"check": self.check, "solver": self.solver, "quantity": self.quantity, "value": _json(self.value),
                "bound": _json(self.bound), "passed": self.passed, "tier": self.tier, "message": self.message}


def _json(v: Any) -> Any:
    return v if not isinstance(v, float) or math.isfinite(v) else str(v)


@dataclass(frozen=True)
class SceneDiff:
    """The checks of one scene: ``match`` "key", "physical", "missing" (only in BASELINE) or "added" (only in
    NEW); ``settings_differ``: "name: base -> new" of a physical match; ``tiers``: solver -> tier used."""

    label: str
    base_key: str
    new_key: str
    match: str
    settings_differ: tuple[str, ...] = ()
    tiers: tuple[tuple[str, str], ...] = ()
    checks: tuple[Check, ...] = ()

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failures(self) -> list[Check]:
        return sorted((c for c in self.checks if not c.passed), key=lambda c: -c.severity)

    @property
    def severity(self) -> float:
        return max((c.severity for c in self.checks), default=0.0)

    @property
    def drifted(self) -> list[Check]:
        """The failed history checks (what ``--figures`` draws)."""
        return [c for c in self.checks if c.check == "history" and not c.passed]

    def to_dict(self) -> dict[str, Any]:
        return {"label": self.label, "baseline_key": self.base_key, "new_key": self.new_key, "match": self.match,
                "settings_differ": list(self.settings_differ), "tiers": dict(self.tiers), "passed": self.passed,
                "checks": [c.to_dict() for c in self.checks]}


@dataclass(frozen=True)
class DiffReport:
    """The comparison of two files: per-scene diffs, the expectations violated in NEW, the version changes."""

    baseline: str
    new: str
    scenes: tuple[SceneDiff, ...]
    tolerances: Tolerances = field(default_factory=Tolerances)
    violations: tuple[Violation, ...] = ()
    versions_differ: tuple[str, ...] = ()

    @property
    def passed(self) -> bool:
        return not self.violations and all(s.passed for s in self.scenes)

    @property
    def failed_scenes(self) -> list[SceneDiff]:
        """The scenes with a failed check, worst first."""
        return sorted((s for s in self.scenes if not s.passed), key=lambda s: (-s.severity, s.label))

    def counts(self) -> dict[str, int]:
        out = {"scenes": len(self.scenes), "passed": sum(s.passed for s in self.scenes),
               "failed": sum(not s.passed for s in self.scenes), "expectations_violated": len(self.violations)}
        for m in ("key", "physical", "missing", "added"):
            out[f"matched_by_{m}" if m in ("key", "physical") else m] = sum(s.match == m for s in self.scenes)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"baseline": self.baseline, "new": self.new, "passed": self.passed, "counts": self.counts(),
                "versions_differ": list(self.versions_differ), "tolerances": self.tolerances.to_dict(),
                "expectations": [v.to_dict() for v in self.violations],
                "scenes": [s.to_dict() for s in self.scenes]}


# -- matching -------------------------------------------------------------------------------------


def physical_key(r: SceneResult) -> str:
    """Hash of the physical scene (:data:`compare.physical.PHYSICAL`), whatever the settings."""
    return spec_physical_key(r.spec)


def _settings(r: SceneResult) -> dict[str, Any]:
    """name -> value of every setting of a scene: the scene's own, each solver's explicit and resolved ones."""
    out = spec_settings(r.spec)
    for name, s in r.solutions.items():
        out.update({f"{name}.{n}": x for n, x in s.settings.items()})
    return out


def settings_differ(base: SceneResult, new: SceneResult) -> list[str]:
    """"name: base -> new" for every setting that differs (absent: "-")."""
    a, b = _settings(base), _settings(new)
    return [f"{k}: {a.get(k, '-')} -> {b.get(k, '-')}" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]


def _tiers(base: SceneResult, new: SceneResult, versions: dict[str, tuple[Any, Any]]) -> dict[str, str]:
    """solver -> tier: ``same`` unless the scene's settings, the solver's settings or a version it depends on
    differ."""
    differ = [d.split(":", 1)[0] for d in settings_differ(base, new)]
    scene_wide = any(k in SCENE_SETTINGS for k in differ)
    moved = {None if k in SCENE_SETTINGS else k.split(".", 1)[0] for k in differ}
    moved |= {VERSION_KEYS[k] for k in versions}
    out = {}
    for solver in sorted(set(base.solutions) | set(new.solutions)):
        physics = scene_wide or None in moved or solver in moved
        out[solver] = "physics" if physics else "same"
    return out


def match(base: Sequence[SceneResult], new: Sequence[SceneResult]
          ) -> tuple[list[tuple[SceneResult, SceneResult, str]], list[SceneResult], list[SceneResult]]:
    """(pairs (base, new, "key"|"physical"), unmatched base, unmatched new): by content key, then one-to-one by
    physical scene (a physical scene held by several scenes of a side is left unmatched)."""
    nk = {r.key: r for r in new}
    pairs = [(b, nk[b.key], "key") for b in base if b.key in nk]
    done = {b.key for b, _, _ in pairs}
    left_b = [b for b in base if b.key not in done]
    left_n = [n for n in new if n.key not in done]
    groups: dict[str, tuple[list[SceneResult], list[SceneResult]]] = {}
    for side, rs in ((0, left_b), (1, left_n)):
        for r in rs:
            groups.setdefault(physical_key(r), ([], []))[side].append(r)
    missing, added = [], []
    for bs, ns in groups.values():
        if len(bs) == 1 and len(ns) == 1:
            pairs.append((bs[0], ns[0], "physical"))
        else:
            missing += bs
            added += ns
    return pairs, missing, added


# -- checks ---------------------------------------------------------------------------------------


def _same_grid(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    return a is not None and b is not None and a.shape == b.shape and bool(np.allclose(a, b, rtol=0, atol=1e-12))


def scene_checks(base: SceneResult, new: SceneResult, tiers: dict[str, str], tol: Tolerances) -> list[Check]:
    """Every check of one matched scene (see the module docstring)."""
    label, key = new.spec.label, new.key
    out: list[Check] = []

    def add(check: str, solver: str, quantity: str, value: Any, bound: Any, passed: bool, tier: str = "",
            message: str = "") -> None:
        out.append(Check(label, key, check, solver, quantity, value, bound, passed, tier, message))

    if base.ok and not new.ok:
        add("status", "", "scene", f"ok -> {new.status}", "ok", False,
            message=f"failed at {new.stage}: {new.message}"[:200])
    elif not base.ok and new.ok:
        add("status", "", "scene", f"{base.status} -> ok", "ok", True, message="a failed scene now solves")
    for name, sb in base.solutions.items():
        sn = new.solutions.get(name)
        if sb.ok and (sn is None or not sn.ok):
            add("status", name, "solver", f"ok -> {'absent' if sn is None else sn.status}", "ok", False,
                message="" if sn is None else sn.message[:200])
    for name, sn in new.solutions.items():
        for comp, h in (sn.histories if sn.ok else sn.deflection).items():
            bad = int(np.size(h) - np.count_nonzero(np.isfinite(h)))
            if bad:
                add("finite", name, comp, f"{bad} non-finite value(s)", "all finite", False)
    same_grid = _same_grid(base.crank_angle, new.crank_angle)
    for name, sb in base.solutions.items():
        sn = new.solutions.get(name)
        if not (sb.ok and sn is not None and sn.ok):
            continue
        if not same_grid:
            add("history", name, "grid", "not compared", "same grid", True, tiers.get(name, ""),
                "the crank-angle grids differ (another step_deg): only the verdict errors are compared")
            continue
        b = tol.bounds(tiers.get(name, "physics"), name)
        for comp, hb in sb.histories.items():
            hn = sn.histories.get(comp)
            if hn is None:
                add("history", name, comp, "absent", "stored", False, tiers.get(name, ""))
                continue
            if hn.shape != hb.shape or not np.all(np.isfinite(hn)):
                continue  # reported by status/finite
            diff = float(np.max(np.abs(hn - hb))) if hb.size else 0.0
            pk = float(np.max(np.abs(hb))) if hb.size else 0.0
            rel = diff / pk if pk > 0 else (0.0 if diff == 0 else math.inf)
            floor = b.history_abs * pk if is_stress(comp) else b.history_abs  # stresses [Pa]: no metre floor
            ok = diff <= max(b.history * pk, floor)
            add("history", name, comp, rel, b.history, ok, tiers.get(name, ""),
                f"max |new - base| = {diff:.3g} (peak {pk:.3g}; floor {b.history_abs:g})")
    for pname, mb in base.metrics.items():
        mn = new.metrics.get(pname)
        if mn is None:
            continue
        tier = "physics" if "physics" in (tiers.get(mb.solver), tiers.get(mb.reference)) else "same"
        add("verdict", mb.solver, pname, f"{_holds(mb.holds)} -> {_holds(mn.holds)}", _holds(mb.holds),
            mb.holds == mn.holds, tier,
            f"verdict_error {mb.verdict_error:.4g} -> {mn.verdict_error:.4g} (tolerance {mn.tolerance:g})")
        if mb.stress_holds is not None and mn.stress_holds is not None:
            add("verdict", mb.solver, f"{pname}/stress", f"{_holds(mb.stress_holds)} -> {_holds(mn.stress_holds)}",
                _holds(mb.stress_holds), mb.stress_holds == mn.stress_holds, tier,
                f"stress error {mb.stress_error:.4g} -> {mn.stress_error:.4g} (tolerance {mn.tolerance:g})")
        bound = max(tol.bounds(tier, mb.solver).verdict_error, tol.bounds(tier, mb.reference).verdict_error)
        d = abs(mn.verdict_error - mb.verdict_error)
        add("verdict_error", mb.solver, pname, d if math.isfinite(d) else math.inf, bound, d <= bound, tier,
            f"{mb.verdict_error:.6g} -> {mn.verdict_error:.6g}")
    return out


def _holds(h: bool) -> str:
    return "holds" if h else "fails"


def _versions(base_info: dict[str, Any], new_info: dict[str, Any]) -> dict[str, tuple[Any, Any]]:
    return {k: (base_info.get(k), new_info.get(k)) for k in VERSION_KEYS if base_info.get(k) != new_info.get(k)}


def diff_results(base: Sequence[SceneResult], new: Sequence[SceneResult], tolerances: Tolerances | None = None,
                 expect: Expectations | None = None, base_info: dict[str, Any] | None = None,
                 new_info: dict[str, Any] | None = None, names: tuple[str, str] = ("BASELINE", "NEW")) -> DiffReport:
    """The :class:`DiffReport` of two sets of scenes (``*_info``: the files' attributes, for their versions)."""
    tol = tolerances or Tolerances()
    versions = _versions(base_info or {}, new_info or {})
    pairs, missing, added = match(base, new)
    scenes = []
    for b, n, how in pairs:
        tiers = _tiers(b, n, versions)
        differ = tuple(settings_differ(b, n)) if how == "physical" else ()
        scenes.append(SceneDiff(n.spec.label, b.key, n.key, how, differ, tuple(sorted(tiers.items())),
                                tuple(scene_checks(b, n, tiers, tol))))
    for b in missing:
        scenes.append(SceneDiff(b.spec.label, b.key, "", "missing", checks=(Check(
            b.spec.label, b.key, "missing", "", "scene", "not in NEW", "present", False,
            message="in BASELINE, no scene of NEW has its key or its physical scene"),)))
    for n in added:
        scenes.append(SceneDiff(n.spec.label, "", n.key, "added", checks=(Check(
            n.spec.label, n.key, "added", "", "scene", "not in BASELINE", "present", False,
            message="in NEW only: no baseline to compare with (regenerate the baseline)"),)))
    violations = tuple(check_expectations(new, expect)) if expect else ()
    vtext = tuple(f"{k}: {a} -> {b}" for k, (a, b) in versions.items())
    return DiffReport(names[0], names[1], tuple(sorted(scenes, key=lambda s: (s.label, s.new_key or s.base_key))),
                      tol, violations, vtext)


def diff_files(baseline: str | Path, new: str | Path, tolerances: Tolerances | None = None,
               expect: Expectations | None = None) -> DiffReport:
    """:func:`diff_results` of two results files (a file that is not a readable results file raises
    :class:`compare.store.StoreError`).  Scenes stored identically in both (same description, status, solver
    settings and bit-identical arrays) are judged from the files' tables without reading them as scenes (every
    drift is zero, every verdict unchanged); only the others are read by :func:`compare.store.read_scenes` (and
    every scene of NEW when expectations are checked)."""
    from compare import store

    base_info, new_info = store.file_info(baseline), store.file_info(new)
    versions = _versions(base_info, new_info)
    same, keys_b, keys_n = identical_scenes(baseline, new, versions, tolerances or Tolerances())
    rest_b, rest_n = [k for k in keys_b if k not in same], [k for k in keys_n if k not in same]
    rep = diff_results(_read(baseline, rest_b, len(keys_b)), _read(new, rest_n, len(keys_n)), tolerances, None,
                       base_info, new_info, (str(baseline), str(new)))
    violations = tuple(check_expectations(store.read_scenes(new), expect)) if expect else ()
    scenes = sorted((*rep.scenes, *same.values()), key=lambda s: (s.label, s.new_key or s.base_key))
    return dataclasses.replace(rep, scenes=tuple(scenes), violations=violations)


def _read(path: str | Path, keys: list[str], n_all: int) -> list[SceneResult]:
    """The scenes ``keys`` of a file (all of them read when they are most of the file, then filtered)."""
    from compare import store

    if not keys:
        return []
    wanted = set(keys)
    return [r for r in store.read_scenes(path, None if 2 * len(keys) > n_all else keys) if r.key in wanted]


def _light(f: Any) -> dict[str, dict[str, Any]]:
    """key -> the table data of every complete scene of a version-4 file: label, status, description (json),
    solution rows (solver, status, settings, flags) and stored pairs ((solver, reference) -> (holds, verdict
    error))."""
    from compare import h5layout, tables

    raw = {name: tables.read_raw(f[name]) if name in f else {} for name in
           (h5layout.SCENE_TABLE, h5layout.SOLUTION_TABLE, h5layout.METRIC_TABLE)}
    sc = raw[h5layout.SCENE_TABLE]
    if not sc:
        return {}
    out: dict[str, dict[str, Any]] = {}
    for i, k in enumerate(sc["key"]):
        if int(sc["complete"][i]) == 1:
            out[k.decode()] = {"label": sc["label"][i].decode(), "status": sc["status"][i], "json": sc["json"][i],
                               "outputs": sc["outputs"][i].decode(), "solutions": [], "pairs": {}, "stress": {}}
    so = raw[h5layout.SOLUTION_TABLE]
    for i, k in enumerate(so.get("key", ())):
        d = out.get(k.decode())
        if d is not None:
            d["solutions"].append(tuple(so[c][i] for c in ("solver", "status", "settings_json", "flags")))
    mt = raw[h5layout.METRIC_TABLE]
    for i, k in enumerate(mt.get("key", ())):
        d = out.get(k.decode())
        if d is not None:
            pair = (mt["solver"][i].decode(), mt["reference"][i].decode())
            d["pairs"][pair] = (bool(mt["pair_holds"][i]), float(mt["verdict_error"][i]))
            comp = mt["component"][i].decode()
            if is_stress(comp):  # the stress verdict: every link within the tolerance
                links = d["stress"].setdefault(pair, {})
                links[comp.removeprefix(STRESS_PREFIX)] = bool(mt["holds"][i])
    return out


def _dataset(fid: Any, path: str) -> np.ndarray | None:
    """A dataset's data by the low-level API (a tenth of the high-level one's cost per dataset); None if
    absent."""
    import h5py

    try:
        d = h5py.h5d.open(fid, path.encode())
    except KeyError:
        return None
    arr = np.empty(d.shape, dtype=d.dtype)
    d.read(h5py.h5s.ALL, h5py.h5s.ALL, arr)
    return arr


def _arrays(f: Any, key: str, solvers: list[str]) -> dict[str, Any]:
    return {name: _dataset(f.id, f"scenes/{key}/{name}") for name in
            ("crank_angle", *(f"solutions/{s}" for s in solvers), *(f"stress/{s}" for s in solvers))}


def _equal(a: dict[str, Any], b: dict[str, Any]) -> bool:
    for name, x in a.items():
        y = b[name]
        if (x is None) != (y is None) or (x is not None and (x.shape != y.shape or not np.array_equal(x, y))):
            return False  # NaN never equals itself: a scene with one is compared in full
    return True


def identical_scenes(baseline: str | Path, new: str | Path, versions: dict[str, tuple[Any, Any]],
                     tol: Tolerances) -> tuple[dict[str, SceneDiff], list[str], list[str]]:
    """(key -> :class:`SceneDiff` of every scene stored identically in both files, the keys of BASELINE, those of
    NEW); ({}, [], []) for files of an older layout (every scene is then read)."""
    import h5py

    from compare import store

    with h5py.File(baseline, "r") as fb, h5py.File(new, "r") as fn:
        if (store.schema_version(fb) or 0) < 4 or (store.schema_version(fn) or 0) < 4:
            return {}, list(store.stored_status(baseline)), list(store.stored_status(new))
        lb, ln = _light(fb), _light(fn)
        out = {}
        for key in lb.keys() & ln.keys():
            b, n = lb[key], ln[key]
            if any(b[c] != n[c] for c in ("json", "status")) or sorted(b["solutions"]) != sorted(n["solutions"]):
                continue
            solvers = [s[0].decode() for s in b["solutions"]]
            ab, an = _arrays(fb, key, solvers), _arrays(fn, key, solvers)
            if not _equal(ab, an):
                continue
            out[key] = _identical_diff(key, n, an, solvers, versions, tol)
    return out, list(lb), list(ln)


def _identical_diff(key: str, row: dict[str, Any], arrays: dict[str, Any], solvers: list[str],
                    versions: dict[str, tuple[Any, Any]], tol: Tolerances) -> SceneDiff:
    """The checks of a scene stored identically in both files: every history drift 0, every verdict unchanged."""
    moved = {VERSION_KEYS[k] for k in versions}
    tiers = {s: "physics" if (None in moved or s in moved) else "same" for s in solvers}
    label = row["label"]
    checks = []
    for s in solvers:
        if arrays.get(f"solutions/{s}") is None or row["status"] != b"ok":
            continue
        stressed = arrays.get(f"stress/{s}") is not None
        links = sorted({lk for stress in row["stress"].values() for lk in stress}) if stressed else []
        for comp in [c for c in row["outputs"].split(",") if c and c != STRESS] + [STRESS_PREFIX + lk for lk in links]:
            checks.append(Check(label, key, "history", s, comp, 0.0, tol.bounds(tiers[s], s).history, True,
                                tiers[s], "identical"))
    for (s, ref), (holds, err) in sorted(row["pairs"].items()):
        tier = "physics" if "physics" in (tiers.get(s), tiers.get(ref)) else "same"
        checks.append(Check(label, key, "verdict", s, f"{s}_vs_{ref}", f"{_holds(holds)} -> {_holds(holds)}",
                            _holds(holds), True, tier, "identical"))
        if (s, ref) in row["stress"]:
            sh = all(row["stress"][(s, ref)].values())
            checks.append(Check(label, key, "verdict", s, f"{s}_vs_{ref}/stress", f"{_holds(sh)} -> {_holds(sh)}",
                                _holds(sh), True, tier, "identical"))
        bound = max(tol.bounds(tier, s).verdict_error, tol.bounds(tier, ref).verdict_error)
        checks.append(Check(label, key, "verdict_error", s, f"{s}_vs_{ref}", 0.0, bound, True, tier,
                            f"{err:.6g} -> {err:.6g}"))
    return SceneDiff(label, key, key, "key", (), tuple(sorted(tiers.items())), tuple(checks))


def regression_tables(doc: dict[str, Any]) -> tuple[Tolerances | None, Expectations | None, list[str]]:
    """The ``[tolerances]`` and ``[expect]`` tables of a parsed TOML document (None where absent) and their
    problems (``"toml.path: message"``)."""
    from compare.expect import parse_expect
    from compare.tolerances import parse_tolerances
    from ked_quasi.massmodel import MASS_MODELS

    tol = exp = None
    problems: list[str] = []
    if "tolerances" in doc:
        tol, p = parse_tolerances(doc["tolerances"])
        problems += p
    if "expect" in doc:
        exp, p = parse_expect(doc["expect"], MASS_MODELS)
        problems += p
    return tol, exp, problems


def stored_tables(path: str | Path) -> dict[str, Any]:
    """The ``[tolerances]`` and ``[expect]`` tables of the campaign config stored in a results file ({} where
    absent; raises ValueError when the stored text is not TOML)."""
    from compare import store

    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib  # type: ignore[no-redef]
    text = str(store.file_info(path).get("campaign_config", "") or "")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: its stored campaign config is not TOML ({exc})") from None
    return {k: doc[k] for k in ("tolerances", "expect") if k in doc}


# -- output ---------------------------------------------------------------------------------------

WIDTH = 100


def _fit(text: str, n: int) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


def _value_text(v: Any, unit: str = "%") -> str:
    """A drift as a percentage of the peak (``%``) or in points of an error (``pt``); text as it is."""
    if isinstance(v, float):
        return f"{100 * v:.3g} {unit}" if math.isfinite(v) else str(v)
    return str(v)


def _unit(c: Check) -> str:
    return "pt" if c.check == "verdict_error" else "%"


def format_report(rep: DiffReport, width: int = WIDTH) -> str:
    """The report as text of at most ``width`` columns: one line per failing scene (its worst check; drifts of
    histories in % of the baseline's peak, of verdict errors in points), worst first, the violated expectations,
    the scenes matched by physical scene with the settings that differ, and a closing count."""
    lines = []
    failed = rep.failed_scenes
    if failed:
        head = f"{'scene (+ more failed checks)':<36} {'check':<13} {'solver/quantity':<22} {'value':>14} {'bound':>10}"
        lines += [head[:width], "-" * min(width, len(head))]
        for s in failed:
            c = s.failures[0]
            more = f" (+{len(s.failures) - 1})" if len(s.failures) > 1 else ""
            scene = _fit(s.label, 36 - len(more)) + more
            what = c.quantity if c.quantity.startswith(f"{c.solver}_vs_") else c.name[len(c.check) + 1:]
            value, bound = _value_text(c.value, _unit(c)), _value_text(c.bound, _unit(c))
            lines.append(f"{scene:<36} {_fit(c.check, 13):<13} {_fit(what, 22):<22} {_fit(value, 14):>14} "
                         f"{_fit(bound, 10):>10}"[:width])
    for v in rep.violations:
        lines.append(_fit(f"EXPECT {v.message}", width))
    for s in rep.scenes:
        if s.match == "physical" and s.settings_differ:
            lines.append(textwrap.fill(f"{s.label}: matched by physical scene; settings differ: "
                                       + "; ".join(s.settings_differ), width=width, subsequent_indent="  ",
                                       break_long_words=False, break_on_hyphens=False))
    for v in rep.versions_differ:
        lines.append(_fit(f"version differs: {v}", width))
    c = rep.counts()
    summary = (f"{'PASS' if rep.passed else 'FAIL'}: {c['passed']} of {c['scenes']} scenes within tolerance "
               f"({c['matched_by_key']} matched by key, {c['matched_by_physical']} by physical scene, "
               f"{c['missing']} missing, {c['added']} added); {c['expectations_violated']} expectation(s) violated")
    last = textwrap.fill(summary, width=width, subsequent_indent="  ")
    return "\n".join([*lines, last])


def junit_xml(rep: DiffReport) -> str:
    """JUnit XML: one test case per scene and check (classname: the scene's label), one per violated
    expectation."""
    import xml.etree.ElementTree as ET

    cases = [(s.label, c.name, c) for s in rep.scenes for c in s.checks]
    suite = ET.Element("testsuite", name="ked diff", tests=str(len(cases) + len(rep.violations)),
                       failures=str(sum(not c.passed for _, _, c in cases) + len(rep.violations)), errors="0")
    for label, name, c in cases:
        case = ET.SubElement(suite, "testcase", classname=label, name=name)
        if not c.passed:
            f = ET.SubElement(case, "failure",
                              message=f"{c.name}: {_value_text(c.value, _unit(c))} beyond "
                                      f"{_value_text(c.bound, _unit(c))}")
            f.text = c.message
    for v in rep.violations:
        case = ET.SubElement(suite, "testcase", classname=v.scene, name=f"expect {v.quantity}")
        ET.SubElement(case, "failure", message=v.message)
    root = ET.Element("testsuites")
    root.append(suite)
    return ET.tostring(root, encoding="unicode", xml_declaration=True)
