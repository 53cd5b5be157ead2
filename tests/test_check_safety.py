"""The design check is safe: on crank-rockers that are not in the atlas and on atlas families near their
quasi-static 10 % limit r*, `ked check` without `--confirm` never says "quasi-static" where Exudyn
measures the quasi-static answer more than 10 % off.

Each case runs `ked check --confirm` over a few speed ratios r = Omega/omega1_min bracketing where the
quasi-static error crosses 10 %; ``predicted_tier`` is what the prediction alone said, and
``confirmed.quasi_static_vs_dynamic`` the quasi-static error Exudyn measures (the verdict measure: the
history error of the deflection vector of P).  The expected value is physics, not the code's output: the
independent Exudyn flexible multibody model is the reference, and the tolerance (10 %) is the check's own.
Run with ``pytest -m slow tests/test_check_safety.py -s`` to see the table of predicted against measured
tiers.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from compare.config import load_linkage
from compare.execute import frame
from ked_check.check import check, spec_for
from ked_quasi import units
from ked_quasi.linkage import FourBar
from ked_quasi.massmodel import MassModel
from ked_quasi.scene import variant
from ked_research.atlas import store as atlas_store
from ked_research.atlas.analysis import default_path
from ked_research.atlas.generate import Linkage, candidate

from .test_cli_linkage import LINKAGE as STEEL_CAMPAIGN

pytestmark = pytest.mark.slow

TOLERANCE = 0.10
TEXTBOOK_RATIOS = (0.065, 0.08, 0.10, 0.14, 0.2)
"""Speed ratios of the non-atlas cases: the quasi-static error of a steel crank-rocker crosses 10 % near
r ~ 0.08-0.15 (e ~ r^2 / (1 - r^2) for one mode, more with several), so these bracket it."""
ATLAS_FRACTIONS = (0.7, 0.8, 0.9, 1.0, 1.15)
"""Speed ratios of the atlas cases as fractions of the family's stored r* (quasi-static vs linear 10 %,
interpolated on the atlas's ratio grid): the holds band (predicted error < 0.6 x tolerance) ends near
0.77 r* since the error grows like r^2; 1.15 r* is past the crossing."""
MASS_MODELS = (MassModel("tip", payload=0.5), MassModel("distributed", payload=0.1))
"""Tip: massless links and a 0.5 kg payload at P; distributed: the steel links' own mass in lumps plus
0.1 kg at P."""
ATLAS_SEED = 0
GENERATED_SEED = 20261124
"""Seed of the non-atlas generated linkages: the atlas's own documented draw (ked_research.atlas.generate:
Grashof crank-rocker with margin, toggle bound, its ranges) with another seed, steel designs only."""

NORTON_P4_1A = """
# Norton, Design of Machinery, Table P4-1 row a: ground 6 in, crank 2 in, coupler 7 in, follower 9 in,
# coupler point R_pa = 6 in at delta_3 = 30 deg from A->B; here with 10 mm round steel links.
[linkage]
crank = 0.0508
coupler = 0.1778
follower = 0.2286
extender = 0.1524
coupler_angle_deg = 30.0
ground = 0.1524
branch = "open"
[linkage.section]
youngs_modulus = 210.0e9
area = 7.853981633974483e-05
second_moment = 4.908738521234052e-10
density = 7850.0
"""

STEEL_EXAMPLE = STEEL_CAMPAIGN
"""The harness's steel example linkage (a campaign config is a linkage file: its [linkage] table is read):
10 mm square steel bar, links 0.05 / 0.15 / 0.12 m, ground 0.14 m, P 0.08 m from A at 30 deg."""


@dataclass(frozen=True)
class Case:
    name: str
    fourbar: FourBar
    mechanism: str
    mass_model: MassModel
    ratios: tuple[float, ...]
    toml: Path | None = None
    """A linkage file: run through the real command line (a subprocess) instead of in-process."""


@dataclass(frozen=True)
class Outcome:
    case: Case
    ratio: float
    rpm: float
    predicted: str
    predicted_error: float
    qs_vs_dynamic: float
    linear_vs_dynamic: float


def _atlas_ratios() -> np.ndarray:
    """(crank, coupler, follower) / ground of every linkage the atlas drew, (n, 3)."""
    lk = atlas_store.read(default_path(), "linkages")
    return np.column_stack([np.asarray(lk[k], float) for k in ("crank_ratio", "coupler_ratio", "follower_ratio")])


def _not_in_atlas(fb: FourBar, atlas: np.ndarray) -> bool:
    """No atlas linkage has the same proportions within 1 % on all three ratios."""
    g = math.dist(fb.crank_pivot, fb.follower_pivot)
    mine = np.array([fb.crank, fb.coupler, fb.follower]) / g
    return not np.any(np.all(np.abs(atlas / mine - 1.0) < 0.01, axis=1))


def _drivable(fb: FourBar) -> tuple[str, ...]:
    try:
        variant(fb, "cognate")
    except ValueError:
        return ("source",)
    return ("source", "cognate")


def _generated(n: int) -> list[Linkage]:
    """The first ``n`` accepted steel linkages of :data:`GENERATED_SEED`."""
    out, index = [], 0
    while len(out) < n:
        c = candidate(GENERATED_SEED, index)
        if isinstance(c, Linkage) and c.design.material == "steel":
            out.append(c)
        index += 1
    return out


def _non_atlas_cases(tmp: Path) -> list[Case]:
    atlas = _atlas_ratios()
    cases = []
    for name, text in (("norton-P4-1a", NORTON_P4_1A), ("steel-example", STEEL_EXAMPLE)):
        path = tmp / f"{name}.toml"
        path.write_text(text)
        fb = load_linkage(path)
        assert _not_in_atlas(fb, atlas), name
        cases += [Case(name, fb, mech, mm, TEXTBOOK_RATIOS, path) for mech in _drivable(fb) for mm in MASS_MODELS]
    for lk in _generated(2):
        assert _not_in_atlas(lk.fourbar, atlas), lk.index
        name = f"seed{GENERATED_SEED}-{lk.index}"
        cases += [Case(name, lk.fourbar, mech, mm, TEXTBOOK_RATIOS) for mech in lk.mechanisms for mm in MASS_MODELS]
    return cases


def _atlas_cases() -> list[Case]:
    """One family per mass model (tip, distributed, extender), each of another linkage: the lowest linkage
    index whose stored 10 % limit r* was crossed on the grid at 0.08 <= r* <= 0.2, rebuilt from
    the atlas's seeded draw; speeds at :data:`ATLAS_FRACTIONS` of r*."""
    fam = atlas_store.read(default_path(), "families")
    cases, used = [], set()
    r10 = np.asarray(fam["r10"], float)
    for mm_name, mech in (("tip", "source"), ("distributed", "cognate"), ("extender", "source")):
        ok = ((np.asarray(fam["mass_model"], dtype=object) == mm_name)
              & (np.asarray(fam["mechanism"], dtype=object) == mech)
              & (np.asarray(fam["r10_status"], dtype=object) == "crossed") & (r10 >= 0.08) & (r10 <= 0.2)
              & ~np.isin(np.asarray(fam["linkage"], float), list(used)))
        row = int(np.flatnonzero(ok)[0])
        used.add(float(fam["linkage"][row]))  # a different linkage for each mass model
        lk = candidate(ATLAS_SEED, int(fam["linkage"][row]))
        assert isinstance(lk, Linkage)
        mm = next(m for m in lk.mass_models if m.name == mm_name)
        assert math.isclose(mm.payload, float(fam["payload_kg"][row]), rel_tol=1e-9)  # the same family
        cases.append(Case(f"atlas-{lk.index}", lk.fourbar, mech, mm, tuple(f * r10[row] for f in ATLAS_FRACTIONS)))
    return cases


def _rpms(case: Case) -> list[float]:
    """The crank speeds [rev/min] of the case's speed ratios: r x omega1_min, with omega1_min from the
    check's own scene (the frozen linkage's lowest first natural frequency)."""
    w1 = frame(spec_for(case.fourbar, case.mechanism, case.mass_model, 1.0)).omega1_min
    return [units.rad_s_to_rpm(r * w1) for r in case.ratios]


def _run_cli(case: Case, rpms: list[float]) -> list[dict]:
    args = [sys.executable, "-m", "ked_cli", "check", "--linkage", str(case.toml), "--mechanism", case.mechanism,
            "--mass-model", case.mass_model.name, "--payload-kg", repr(case.mass_model.payload), "--confirm", "--json"]
    for rpm in rpms:
        args += ["--rpm", repr(rpm)]
    res = subprocess.run(args, capture_output=True, text=True, timeout=1800)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def _run(case: Case) -> list[Outcome]:
    rpms = _rpms(case)
    if case.toml is not None:
        rows = _run_cli(case, rpms)
    else:
        rows = [{"rpm": r.rpm, "speed_ratio": r.speed_ratio, "predicted_tier": r.predicted_tier,
                 "linear_vs_quasi_static": r.linear_vs_quasi_static, "confirmed": r.confirmed}
                for r in check(case.fourbar, case.mechanism, case.mass_model, rpms, confirm=True)]
    nan = math.nan
    return [Outcome(case, row["speed_ratio"], row["rpm"], row["predicted_tier"],
                    nan if row["linear_vs_quasi_static"] is None else row["linear_vs_quasi_static"],
                    nan if row["confirmed"].get("quasi_static_vs_dynamic") is None
                    else row["confirmed"]["quasi_static_vs_dynamic"],
                    nan if row["confirmed"].get("linear_vs_dynamic") is None else row["confirmed"]["linear_vs_dynamic"])
            for row in rows]


def _measured(o: Outcome) -> str:
    if not math.isfinite(o.qs_vs_dynamic):
        return "no Exudyn"
    if o.qs_vs_dynamic < TOLERANCE:
        return "quasi-static"
    return "linear" if o.linear_vs_dynamic < TOLERANCE else "nonlinear"


def _report(outcomes: list[Outcome]) -> None:
    print(f"\n{'linkage':<22} {'mech':<8} {'mass':<12} {'r':>6} {'predicted':<13} {'qs vs lin':>9} "
          f"{'qs vs Exudyn':>12} {'lin vs Exudyn':>13}  measured")
    for o in outcomes:
        print(f"{o.case.name:<22} {o.case.mechanism:<8} {o.case.mass_model.name:<12} {o.ratio:6.3f} "
              f"{o.predicted:<13} {o.predicted_error:9.1%} {o.qs_vs_dynamic:12.1%} {o.linear_vs_dynamic:13.1%}  "
              f"{_measured(o)}")
    counts = Counter((o.predicted, _measured(o)) for o in outcomes)
    print("predicted tier -> measured tier: " + ", ".join(f"{p} -> {m}: {n}" for (p, m), n in sorted(counts.items())))


def test_check_never_calls_quasi_static_where_exudyn_measures_more_than_the_tolerance(tmp_path):
    cases = _non_atlas_cases(tmp_path) + _atlas_cases()
    assert any(c.mechanism == "cognate" for c in cases) and any(c.toml is not None for c in cases)
    outcomes = [o for c in cases for o in _run(c)]
    _report(outcomes)
    confirmed = [o for o in outcomes if math.isfinite(o.qs_vs_dynamic)]
    # the speeds bracket the threshold: Exudyn measures the quasi-static answer both within and beyond 10 %
    assert any(o.qs_vs_dynamic < TOLERANCE for o in confirmed) and any(o.qs_vs_dynamic > TOLERANCE for o in confirmed)
    # Exudyn answered validly on every scene the check could call quasi-static (only there can a call be unsafe);
    # predicted nonlinear scenes (r = 0.14-0.2) may have no valid Exudyn answer (beyond the small-deflection range)
    assert all(math.isfinite(o.qs_vs_dynamic) for o in outcomes if o.predicted != "nonlinear")
    assert len(confirmed) >= 0.8 * len(outcomes)
    unsafe = [(o.case.name, o.case.mechanism, o.case.mass_model.name, round(o.ratio, 4), o.qs_vs_dynamic)
              for o in confirmed if o.predicted == "quasi-static" and o.qs_vs_dynamic > TOLERANCE]
    assert not unsafe, f"quasi-static predicted, Exudyn measures more than {TOLERANCE:.0%}: {unsafe}"
