"""The validation rules of every scene parameter, defined once.

The dataclasses (:class:`~ked_quasi.linkage.Section`, :class:`~ked_quasi.linkage.FourBar`,
:class:`~ked_quasi.massmodel.MassModel`, :class:`~ked_quasi.scene.Scene`), the campaign TOML loader
and the command line all check a value with the same :class:`Rule`, so a value accepted by one is
accepted by all, and every refusal says what is allowed and why.  Units: SI unless the rule's
``unit`` says otherwise (rpm, deg).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class Rule:
    """An allowed range for one parameter.

    ``name``: the parameter as users know it; ``unit``: its unit (text); ``lo``/``hi``: bounds (None =
    unbounded); ``lo_open``/``hi_open``: strict bounds; ``integer``: whole numbers only; ``why``: the
    reason for the bounds, quoted in every refusal.
    """

    name: str
    unit: str
    lo: float | None
    hi: float | None
    why: str
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    mixup: tuple[str, str, float] | None = None
    """For a value above ``hi``: (what the unit is, the smaller unit a user may have meant, its factor to
    the SI unit), e.g. ("lengths are in metres", "mm", 1e-3): the refusal names the likely mix-up."""
    mixup_low: tuple[str, str, float, str] | None = None
    """For a value below ``lo``: (what the unit is, the larger unit a user may have meant, its factor to the
    SI unit, an example in SI), e.g. ("densities are in kg/m^3", "g/cm^3", 1e3, "7850 kg/m^3 for steel")."""

    def allowed(self) -> str:
        """The allowed range as text, e.g. ``a number in (0, 1e+05] rpm``."""
        kind = "an integer" if self.integer else "a number"
        if self.lo is None and self.hi is None:
            return f"{kind} (finite)"
        lo = "-inf" if self.lo is None else f"{self.lo:g}"
        hi = "inf" if self.hi is None else f"{self.hi:g}"
        left = "(" if self.lo_open or self.lo is None else "["
        right = ")" if self.hi_open or self.hi is None else "]"
        unit = f" {self.unit}" if self.unit else ""
        return f"{kind} in {left}{lo}, {hi}{right}{unit}"

    def check(self, value: object, label: str | None = None) -> float | int:
        """``value`` as float (int for integer rules); ValueError naming ``label`` (default: the rule's
        name), the value, the allowed range and the reason."""
        label = label or self.name
        v = self._number(value, label)
        below = self.lo is not None and (v < self.lo or (self.lo_open and v == self.lo))
        above = self.hi is not None and (v > self.hi or (self.hi_open and v == self.hi))
        if above and self.mixup is not None:
            what, small, factor = self.mixup
            raise ValueError(f"{label} = {v:g} {self.unit}: {what} ({v:g} {small} = {v * factor:g} {self.unit}); "
                             f"must be {self.allowed()} ({self.why})")
        if below and v > 0 and self.mixup_low is not None:
            what, big, factor, example = self.mixup_low
            raise ValueError(f"{label} = {v:g} {self.unit}: {what} ({v:g} {big} = {v * factor:g} {self.unit}; "
                             f"{example}); must be {self.allowed()} ({self.why})")
        if below or above:
            raise ValueError(f"{label}: must be {self.allowed()} ({self.why}); got {value!r}")
        return v

    def _number(self, value: object, label: str) -> float | int:
        if isinstance(value, bool):
            raise ValueError(f"{label}: must be {self.allowed()}; got the boolean {value!r}")
        if isinstance(value, (str, bytes)):
            raise ValueError(f"{label}: must be {self.allowed()}; got the string {value!r} (write numbers without "
                             "quotes)")
        if self.integer:
            if isinstance(value, int) or (hasattr(value, "__index__") and not isinstance(value, float)):
                return int(value)  # type: ignore[call-overload]
            raise ValueError(f"{label}: must be {self.allowed()}; got {value!r}")
        try:
            v = float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise ValueError(f"{label}: must be {self.allowed()}; got {value!r}") from None
        if not math.isfinite(v):
            raise ValueError(f"{label}: must be {self.allowed()}; got {value!r}")
        return v


def check_choice(label: str, value: object, allowed: tuple[str, ...]) -> str:
    """``value`` if it is one of ``allowed``; ValueError naming ``label`` and the choices otherwise."""
    if not isinstance(value, str) or value not in allowed:
        raise ValueError(f"{label}: must be one of {', '.join(allowed)}; got {value!r}")
    return value


@dataclass(frozen=True)
class Choice:
    """The allowed words of one parameter (same interface as :class:`Rule`)."""

    name: str
    choices: tuple[str, ...]
    why: str = ""

    def allowed(self) -> str:
        return f"one of {', '.join(self.choices)}"

    def check(self, value: object, label: str | None = None) -> str:
        """``value`` if it is one of the choices; ValueError naming ``label`` and the choices otherwise."""
        return check_choice(label or self.name, value, self.choices)


@dataclass(frozen=True)
class Flag:
    """A yes/no parameter: True or False only (same interface as :class:`Rule`)."""

    name: str
    why: str = ""

    def allowed(self) -> str:
        return "true or false"

    def check(self, value: object, label: str | None = None) -> bool:
        if not isinstance(value, bool):
            raise ValueError(f"{label or self.name}: must be true or false; got {value!r}")
        return value


def check_fields(obj: object, rules_of: Mapping[str, Rule | Choice | Flag]) -> None:
    """Check every field of the frozen dataclass ``obj`` named in ``rules_of`` with its rule and store the
    checked value (float or int as the rule says); a field whose default is None accepts None ("automatic").
    The settings classes of every solver call this from ``__post_init__``, so that the class and the
    campaign config (which checks each key with the same rule) accept exactly the same values."""
    cls = type(obj).__name__
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        rule = rules_of.get(f.name)
        if rule is None:
            continue
        value = getattr(obj, f.name)
        if value is None and (f.default is None or "None" in str(f.type)):
            continue
        object.__setattr__(obj, f.name, rule.check(value, f"{cls}.{f.name}"))


# -- linkage ------------------------------------------------------------------------------------
LENGTH = Rule("length", "m", 0.0, 10.0, "a link of a machine linkage, up to 10 m", lo_open=True,
              mixup=("lengths are in metres", "mm", 1e-3))
COORDINATE = Rule("pivot coordinate", "m", -1e3, 1e3, "pivots within 1 km of the origin")
COUPLER_ANGLE_DEG = Rule("coupler_angle_deg", "deg", -360.0, 360.0, "one turn either way")
COUPLER_ANGLE = Rule("coupler_angle", "rad", -2.0 * math.pi, 2.0 * math.pi, "one turn either way")
YOUNGS_MODULUS = Rule("youngs_modulus", "Pa", 0.0, 1e18, "any material, times a stiffness scale of up to 1e6",
                      lo_open=True)
MIN_TRANSMISSION_DEG = 10.0
"""Smallest distance of the transmission angle mu (at B, between B->A and B->Q) from a toggle (0 or 180
deg) accepted over a full crank turn [deg].  At a toggle the frozen structure is singular (the pin-force
solve is amplified by 1/|sin mu|, 5.8 at this bound, infinite at a change point): every solver's answer
near it is dominated by that singularity, not by the elastodynamics the harness compares.  The atlas
samples only linkages at twice this bound (20 deg), so every linkage it holds is accepted."""
AREA = Rule("area", "m^2", 0.0, 1.0, "a link's cross-section, at most a 1 m square", lo_open=True,
            mixup=("areas are in m^2", "mm^2", 1e-6))
SECOND_MOMENT = Rule("second_moment", "m^4", 0.0, 1.0, "a link's cross-section (a 1 m square has 1/12 m^4; the "
                     "closed-form checks use stiff links up to 1 m^4)", lo_open=True,
                     mixup=("second moments are in m^4", "mm^4", 1e-12))
FIBRE_DISTANCE = Rule("fibre_distance", "m", 0.0, 10.0, "the distance of a link's extreme fibre from its "
                      "neutral axis (half the depth of the section)", lo_open=True,
                      mixup=("distances are in metres", "mm", 1e-3))
DENSITY = Rule("density", "kg/m^3", 0.0, 1e5, "up to 4x the densest metal", lo_open=True)
MATERIAL_YOUNGS_MODULUS = Rule(
    "youngs_modulus", "Pa", 1e8, 2e12, "a link's material: from stiff polymers (PTFE 0.5 GPa) to diamond "
    "(1.1e12 Pa)", mixup_low=("moduli are in Pa", "MPa", 1e6, "steel: 210 GPa = 2.1e11 Pa"))
MATERIAL_DENSITY = Rule(
    "density", "kg/m^3", 100.0, 1e5, "a link's material: from balsa wood (~150 kg/m^3) to 4x the densest metal",
    mixup_low=("densities are in kg/m^3", "g/cm^3", 1e3, "steel: 7850 kg/m^3"))
USER_SECTION_RULES = {"youngs_modulus": MATERIAL_YOUNGS_MODULUS, "area": AREA, "second_moment": SECOND_MOMENT,
                      "density": MATERIAL_DENSITY}
"""Plausibility bounds of a user's material constants (TOML files and the command line), naming the likely
unit mix-up.  The :class:`~ked_quasi.linkage.Section` dataclass keeps the wider physical ranges of
:data:`YOUNGS_MODULUS` and :data:`DENSITY`: a scaled modulus (``stiffness_scale`` from 1e-6 to 1e6) and the
idealized sections of closed-form checks (nearly massless links) are sections too, but no material."""
STIFFNESS_SCALE = Rule("stiffness_scale", "", 0.0, 1e6, "a factor on every Young's modulus", lo_open=True)

# -- mass model ---------------------------------------------------------------------------------
LUMPS = Rule("lumps", "per link", 1, 256, "lumps at the segment ends need more than 64 per link for 1 % (the "
             "work-precision study's convergence reference is 256); each lump adds two coordinates to every "
             "frozen structure", integer=True)
DEFAULT_LUMPS = 20
"""Lumps per distributed link when none is given: the lumping error of the quasi-static coupler-point history
is then ~0.3 % of its peak (midpoint lumps converge as 1/lumps^2; against Exudyn's continuous beams on the atlas's
distributed scenes near the 10 % margin: 1.0-2.3 % with 5 lumps, 0.2-0.5 % with 20; docs/linear_model.md).  The
linear KED model carries the inertia of the elastic motion on fewer (``LinearSettings.dynamic_lumps``)."""
PAYLOAD_KG = Rule("payload_kg", "kg", 0.0, 1e4, "a point mass a linkage can carry, up to 10 t")
JOINT_SPLIT = Rule("joint_split", "", 0.0, 1.0, "the fraction of a link's mass at its root end")

# -- speed and grid -----------------------------------------------------------------------------
RPM = Rule("rpm", "rev/min", 0.0, 1e5, "crank speeds of real machinery, up to 100 000 rpm", lo_open=True)
MIN_SPEED_RATIO = 1e-4
"""Slowest crank speed accepted, as r = Omega/omega1_min.  Below it the dynamic part of the response (of
order r^2 = 1e-8 of the quasi-static deflection) is below what any solver resolves (Newton tolerances,
round-off), so no tier can say anything the quasi-static answer does not; the Exudyn model's low-speed step
error grows like 1/r (exudyn_models.lowspeed: thousands of steps per cycle at this bound, and a period of
10^4 natural periods), and far below it the inertia loads underflow (1e-100 rpm gives NaN deflections).
The harness's slowest scenes (1 rpm on the thesis linkage, r ~ 2e-3) are well above it."""
SPEED_RATIO = Rule("speed_ratio", "", MIN_SPEED_RATIO, 10.0,
                   "crank speed over the lowest first natural frequency of the frozen linkage; below 1e-4 the "
                   "dynamic part is below every solver's resolution")
STEP_DEG = Rule("step_deg", "deg", 0.01, 45.0,
                "at least 8 samples per turn to resolve peaks and harmonics, at most 36 000 angles; "
                "it must divide 360")
DEFAULT_DAMPING_RATIO = 0.02
"""The modal damping ratio of every solver, campaign and check when none is given (2 %, steel linkages)."""
DAMPING_RATIO = Rule("damping_ratio", "", 0.0, 0.99, "a modal damping ratio below critical")
DAMPING_REFERENCE_HZ = Rule("damping_reference_hz", "Hz", 0.0, 1e6, "the frequency at which the damping ratio "
                            "holds: a natural frequency of the linkage", lo_open=True)
N_MODES = Rule("n_modes", "", 1, 20, "natural frequencies stored per crank angle", integer=True)
DEFAULT_TOLERANCE = 0.10
"""The verdict tolerance of every campaign and check when none is given (10 % of the reference's peak)."""
TOLERANCE = Rule("tolerance", "", 0.0, 10.0, "the relative error of a verdict", lo_open=True)

MAX_SCENES = 100_000
"""Largest campaign grid accepted at load [scenes].  Measured on the project's 2-core, 23 GB machine: a
96 000-scene quasi-static grid loads, expands and plans (``ked run --dry-run``) in about 6 s and 180 MB,
so a grid of millions of scenes takes minutes and gigabytes before anything runs; a stored scene takes
25-80 kB of results file (about 2.5-8 GB at the cap), and even quasi-static scenes at tens of ms each
take hours at the cap.  A larger study is split into campaigns (several results files, joined with
``ked merge``)."""

SPEED_RATIO_LOAD_STEP_DEG = 30.0
"""Crank-angle step [deg] of the quick omega1_min estimate that screens crank speeds at load; a speed
whose estimated r exceeds :data:`SPEED_RATIO_SCREEN` x the bound is checked again with the scene's own
step and lumps (what the run computes), and refused only if that r exceeds the bound."""

SPEED_RATIO_LOAD_LUMPS = 8
"""Lumps per link of the quick omega1_min estimate (the scene's own count when smaller)."""

SPEED_RATIO_SCREEN = 0.5
"""Fraction of the r bound above which the quick estimate is confirmed with the exact omega1_min."""

MAX_WORK = 4e8
"""Bound on crank angles x (coordinates of the frozen structure)^2 in one solve: the flexibility and
frequency arrays hold that many numbers (8 bytes each, 3.2 GB at the bound)."""


def check_step_deg(value: object, label: str = "step_deg") -> float:
    """A crank-angle step [deg] within :data:`STEP_DEG` that divides 360 into whole steps."""
    step = float(STEP_DEG.check(value, label))
    n = 360.0 / step
    if abs(n - round(n)) > 1e-9 * n:
        raise ValueError(f"{label}: must divide 360 deg into whole steps (e.g. 1, 2.5, 5, 10); got {value!r}")
    return step


def steps_per_turn(step_deg: float) -> int:
    """Number of grid angles of a full turn at ``step_deg`` (already checked to divide 360)."""
    return round(360.0 / step_deg)


def check_work(n_angles: int, n_coordinates: int, label: str = "step_deg and lumps") -> None:
    """Refuse a solve whose per-angle matrices would not fit in memory (see :data:`MAX_WORK`)."""
    work = float(n_angles) * float(n_coordinates) ** 2
    if work > MAX_WORK:
        raise ValueError(
            f"{label}: {n_angles} crank angles x {n_coordinates} structural coordinates is too large a problem "
            f"(angles x coordinates^2 = {work:.3g} > {MAX_WORK:.0e}, about {8 * work / 1e9:.1f} GB); "
            "use a coarser step_deg or fewer lumps")


def check_transmission(min_deg: float, label: str, at_deg: float, lengths: str) -> None:
    """Refuse a linkage whose smallest transmission angle distance from a toggle, ``min_deg`` [deg] (at
    crank angle ``at_deg``), is below :data:`MIN_TRANSMISSION_DEG`; ``lengths`` describes the links."""
    if not min_deg >= MIN_TRANSMISSION_DEG:
        raise ValueError(
            f"{label}: minimum transmission angle {min_deg:.2f} deg (at crank angle {at_deg:.1f} deg) is below "
            f"{MIN_TRANSMISSION_DEG:g} deg: a change-point or near-change-point linkage ({lengths}), singular at a "
            "toggle; change the link lengths so that the transmission angle stays at least "
            f"{MIN_TRANSMISSION_DEG:g} deg from 0 and 180 deg over the turn")


def check_speed_ratio(ratio: float, rpm: float, f1_hz: float, label: str = "rpm") -> None:
    """Refuse a crank speed ``rpm`` whose speed ratio ``ratio`` = Omega/omega1_min exceeds
    :data:`SPEED_RATIO`'s bound (``f1_hz``: the lowest first natural frequency [Hz]; the message
    names the likely unit mix-up) or lies below :data:`MIN_SPEED_RATIO`."""
    if ratio < MIN_SPEED_RATIO:  # nan (no finite frequency) is not refused
        raise ValueError(
            f"{label} = {rpm:g}: speed ratio r = Omega/omega1_min = {ratio:.3g} below {MIN_SPEED_RATIO:g} (lowest "
            f"first natural frequency {f1_hz:.3g} Hz): at so slow a crank the dynamic part of the response (~r^2 "
            "of the deflection) is below every solver's resolution and the period cannot be simulated in "
            "reasonable steps; crank speeds are in rev/min: raise the speed (the quasi-static answer at "
            f"r = {MIN_SPEED_RATIO:g} is the answer at any slower speed, scaled by (speed ratio)^2)")
    if ratio > SPEED_RATIO.hi:  # type: ignore[operator]  # nan (no finite frequency) is not refused
        raise ValueError(
            f"{label} = {rpm:g}: speed ratio r = Omega/omega1_min = {ratio:.3g} above {SPEED_RATIO.hi:g} (lowest "
            f"first natural frequency {f1_hz:.3g} Hz); crank speeds are in rev/min, lengths in metres, Young's "
            "modulus in Pa, density in kg/m^3: a unit mix-up (e.g. mm as m) or a stiffness scale far below 1 "
            "gives such an r; lower the speed or fix the units")

# -- slider-crank -------------------------------------------------------------------------------
OFFSET = Rule("offset", "m", -10.0, 10.0, "the slider line's distance from the crank pivot, within the link lengths",
              mixup=("offsets are in metres", "mm", 1e-3))
COUPLER_POINT = Rule("coupler_point", "", 0.0, 1.0, "a fraction of the coupler from the crank pin A (0) to the "
                     "slider pin B (1); a point at a pin is that pin", lo_open=True, hi_open=True)
SLIDER_MASS_KG = Rule("slider_mass", "kg", 0.0, 1e4, "a slider a linkage can drive, up to 10 t")


def check_slider_crank_turns(crank: float, coupler: float, offset: float, label: str = "SliderCrank") -> None:
    """Refuse a slider-crank whose crank cannot turn fully: it needs crank + |offset| < coupler (otherwise the
    coupler cannot reach the slider line at some crank angle, or reaches it only at a toggle)."""
    if not crank + abs(offset) < coupler:
        raise ValueError(
            f"{label}: the crank cannot turn fully: crank + |offset| = {crank + abs(offset):g} m must be below the "
            f"coupler length {coupler:g} m (crank={crank:g} m, coupler={coupler:g} m, offset={offset:g} m)")
