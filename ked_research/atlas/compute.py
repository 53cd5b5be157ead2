"""One linkage of the atlas, on a worker: every family (mechanism x mass model) over the speed-ratio sweep.

A scene is a campaign :class:`~compare.scenes.SceneSpec` (speed as r = Omega / omega1_min, 2 % damping,
ccw, 10 deg grid) solved by the registered ``quasi_static`` and ``linear`` solvers with the settings a
campaign would use (:func:`compare.execute.solve_one`, :func:`compare.execute.settings_of`); errors are
:mod:`compare.metrics` vector errors of the coupler point, the quasi-static history against the linear
one (the dynamic part of the quasi-static error).  The sweep of a family walks up the ratio grid and
stops after the first ratio whose error reaches :data:`STOP_ERROR` (twice the largest tolerance: the
limits are known by then); the ratios above are stored as not computed.  Only compact records travel back.

A task first sets the worker process's C allocator to keep freed memory
(:func:`ked_linear.solver.keep_freed_memory`, which ``solve_linear`` also calls): a Dask nanny starts its
workers with ``MALLOC_TRIM_THRESHOLD_=65536``, under which glibc gives every freed block above 64 KiB
back to the operating system and maps it afresh (zeroed pages) at the next allocation; the linear
model's many short-lived arrays of some 100 KiB then cost as much system time in page faults as the
computation itself (twice the CPU time per scene on a Dask worker, measured).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, replace

import numpy as np

from compare import metrics
from compare import solvers as registry
from compare.execute import frame, resolve_rpm, solve_one
from compare.limits import TOLERANCES, Limit, one_mode_curves, one_mode_limit, validity_limit
from compare.scenes import SceneSpec, SpeedSpec
from ked_quasi import kinds, rules
from ked_quasi.harmonics import significant_harmonic
from ked_quasi.massmodel import MassModel
from ked_research.atlas.generate import Linkage

RATIOS = (0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.10, 0.115, 0.13, 0.15, 0.175, 0.2, 0.25, 0.3, 0.4, 0.5)
"""The speed-ratio sweep r = Omega / omega1_min (dense where the limits are)."""
STOP_ERROR = 0.20
DAMPING = rules.DEFAULT_DAMPING_RATIO
STEP_DEG = 10.0
# per-ratio status codes
OK, UNSTABLE, FAILED, NOT_COMPUTED = 0, 1, 2, 3
FLAG_BITS = {"large_deflection": 1, "large_rotation": 2, "non_finite": 4}


@dataclass(frozen=True)
class FamilyRecord:
    """What the atlas keeps of one family (linkage, mechanism, mass model).  Per-ratio tuples follow
    :data:`RATIOS`; errors [1]; frequencies [Hz]; angles [deg]."""

    linkage: int
    mechanism: str
    mass_model: str
    payload_kg: float
    status: str
    reason: str
    omega1_min: float
    f1_min_hz: float
    f1_max_hz: float
    min_transmission_deg: float
    k_sig_1: int
    k_sig_5: int
    history_error: tuple[float, ...]
    peak_error: tuple[float, ...]
    floquet_max_abs: tuple[float, ...]
    linear_error_estimate: tuple[float, ...]
    one_mode_error: tuple[float, ...]
    flags: tuple[int, ...]
    code: tuple[int, ...]
    limits: tuple[Limit, ...]
    one_mode_limits: tuple[float, ...]
    wall_s: float


def failed_record(index: int, mechanism: str, mm: MassModel, reason: str, n: int, wall_s: float = 0.0) -> FamilyRecord:
    """The record of a family that could not be computed (every ratio code :data:`FAILED`)."""
    nan, empty = math.nan, (math.nan,) * n
    return FamilyRecord(index, mechanism, mm.name, mm.payload, "failed", reason[:500], nan, nan, nan, nan, 0, 0,
                        empty, empty, empty, empty, empty, (0,) * n, (FAILED,) * n,
                        tuple(Limit(tol, "no_data") for tol in TOLERANCES), (nan,) * len(TOLERANCES), wall_s)


def spec_of(linkage: Linkage, mechanism: str, mass_model: MassModel, r: float) -> SceneSpec:
    """The campaign scene of one family at speed ratio ``r``."""
    return SceneSpec(linkage=linkage.source, mechanism=mechanism, mass_model=mass_model, speed=SpeedSpec("ratio", r),
                     stiffness_scale=1.0, damping_ratio=DAMPING, direction="ccw", step_deg=STEP_DEG, n_modes=1,
                     outputs=("dx", "dy", "rotation"), tolerance=0.10, dynamic=(("damping_ratio", DAMPING),),
                     solvers=("quasi_static", "linear"))


def xy(sol: registry.Solution) -> np.ndarray:
    """(n, 2) deflection vector of P [m] of a solution."""
    return metrics.vector(sol.deflection)


def flag_bits(flags: tuple[str, ...]) -> int:
    return sum(FLAG_BITS.get(f, 0) for f in flags)


def _loads_and_shape(scene: object) -> tuple[np.ndarray, np.ndarray, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = kinds.model(scene).quasi_static(scene)
    mu = np.asarray(res.transmission_angle)
    return res.loads, res.deflection[:, :2], float(np.degrees(np.min(np.minimum(mu, np.pi - mu))))


@dataclass(frozen=True)
class _Sweep:
    hist: list[float]
    peak: list[float]
    mu: list[float]
    est: list[float]
    flags: list[int]
    code: list[int]
    reason: str


def sweep(linkage: Linkage, mechanism: str, mm: MassModel, omega1_min: float, ratios: tuple[float, ...],
          scene: object | None = None) -> _Sweep:
    """Quasi-static and linear solutions up the ratio grid (stops at :data:`STOP_ERROR`); ``scene``: the
    family's scene at any speed, if built already (it is set to each ratio's speed)."""
    qs, lin = registry.get("quasi_static"), registry.get("linear")
    n, nan = len(ratios), math.nan
    s = _Sweep([nan] * n, [nan] * n, [nan] * n, [nan] * n, [0] * n, [NOT_COMPUTED] * n, "")
    reason = ""
    # the family's scene is built once and set to each speed (a cognate's construction costs about as much
    # as a quasi-static solve)
    base = scene if scene is not None else spec_of(linkage, mechanism, mm, ratios[0]).scene(1.0)
    for i, r in enumerate(ratios):
        spec = spec_of(linkage, mechanism, mm, r)
        scene = replace(base, rpm=resolve_rpm(spec, omega1_min))
        a, b = solve_one(qs, spec, scene), solve_one(lin, spec, scene)
        s.mu[i] = float(b.stats.get("floquet_max_abs", nan))
        s.est[i] = float(b.stats.get("error_estimate", nan))
        if not (a.ok and b.ok):
            s.code[i] = UNSTABLE if b.error_type == "Unstable" else FAILED
            reason = reason or f"r={r:g}: {(b if not b.ok else a).message[:300]}"
            continue
        s.flags[i] = flag_bits(b.flags)
        s.hist[i], s.peak[i] = metrics.history_error(xy(a), xy(b)), metrics.peak_error(xy(a), xy(b))
        s.code[i] = OK
        if s.hist[i] >= STOP_ERROR:
            break
    return _Sweep(s.hist, s.peak, s.mu, s.est, s.flags, s.code, reason)


def family(linkage: Linkage, mechanism: str, mm: MassModel, ratios: tuple[float, ...] = RATIOS) -> FamilyRecord:
    """One family's record (a setup failure is a record with status "failed" and its reason)."""
    t0 = time.perf_counter()
    try:
        fr = frame(spec_of(linkage, mechanism, mm, ratios[0]))
        loads, shape, mu_min = _loads_and_shape(fr.scene)
        s = sweep(linkage, mechanism, mm, fr.omega1_min, ratios, fr.scene)
    except Exception as exc:  # a scene that cannot be set up: kept with its reason
        return failed_record(linkage.index, mechanism, mm, f"{type(exc).__name__}: {exc}", len(ratios),
                             time.perf_counter() - t0)
    ok = [c == OK for c in s.code]
    lims = tuple(validity_limit(ratios, s.hist, ok, tol) for tol in TOLERANCES)
    f1 = fr.natural_frequencies[:, 0]
    return FamilyRecord(
        linkage=linkage.index, mechanism=mechanism, mass_model=mm.name, payload_kg=mm.payload, status="ok",
        reason=s.reason, omega1_min=fr.omega1_min, f1_min_hz=float(np.nanmin(f1)), f1_max_hz=float(np.nanmax(f1)),
        min_transmission_deg=mu_min, k_sig_1=significant_harmonic(loads, 0.01),
        k_sig_5=significant_harmonic(loads, 0.05), history_error=tuple(s.hist), peak_error=tuple(s.peak),
        floquet_max_abs=tuple(s.mu), linear_error_estimate=tuple(s.est),
        one_mode_error=tuple(float(e) for e in one_mode_curves(shape, np.asarray(ratios), DAMPING)["history"]),
        flags=tuple(s.flags), code=tuple(s.code), limits=lims,
        one_mode_limits=tuple(one_mode_limit(shape, tol, DAMPING, "history") for tol in TOLERANCES),
        wall_s=time.perf_counter() - t0,
    )


def families_of(linkage: Linkage) -> tuple[tuple[str, MassModel], ...]:
    """(mechanism, mass model) of every family of a linkage, in the atlas's order."""
    return tuple((mech, mm) for mech in linkage.mechanisms for mm in linkage.mass_models)


def compute_family(linkage: Linkage, mechanism: str, mm: MassModel,
                   ratios: tuple[float, ...] = RATIOS) -> FamilyRecord:
    """One family (the atlas's task, on a worker: :func:`ked_research.atlas.run.run_atlas`)."""
    from ked_linear.solver import keep_freed_memory

    keep_freed_memory()
    return family(linkage, mechanism, mm, ratios)


def compute_linkage(linkage: Linkage, ratios: tuple[float, ...] = RATIOS) -> tuple[FamilyRecord, ...]:
    """Every family of one linkage, in one process."""
    return tuple(compute_family(linkage, mech, mm, ratios) for mech, mm in families_of(linkage))
