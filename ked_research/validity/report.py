"""Validity study: the Markdown section of results/README.md, generated from the family summaries
(every number in it comes from the HDF5 files it was read from)."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from datetime import datetime
from functools import partial
from pathlib import Path

import numpy as np

from compare.limits import TOLERANCES, one_mode_curves, peak_ratio
from compare.markdown import num, pct, table
from ked_quasi.units import rad_s_to_rpm
from ked_research.validity.data import RETRY_MAX_RATIO, RETRY_STEP_FACTOR, Point, run_starts
from ked_research.validity.figures import reference
from ked_research.validity.summary import Answer, Claims, FamilySummary, answer, claims

f3 = partial(num, spec=".3f")
mm = partial(num, spec=".2f", scale=1e3)


def limit_text(fs: FamilySummary, kind: str, tol: float) -> str:
    """'**0.060** (+0.020; interpolated 0.071, fine 0.070)' or the reason there is no crossing: the first
    crossing on the grid (the last passing ratio, the step to the first failing one), the interpolated
    value for reference only."""
    lim = fs.limits[(kind, tol)]
    if lim.status == "crossed":
        fine = fs.refined_cross.get((kind, tol), math.nan)
        note = f"fine {f3(fine)}" if math.isfinite(fine) else (fs.refined_note.get((kind, tol)) or "fine -")
        return f"**{f3(lim.r_limit)}** (+{f3(lim.step)}; interpolated {f3(lim.r_cross)}, {note})"
    if lim.status == "below_grid":
        return f"< {lim.r_fail:g}"
    if lim.status == "above_grid":
        return f">= {lim.r_pass:g} (never exceeded)"
    if lim.status == "failure":
        return f">= {lim.r_pass:g} (dynamic failed at {lim.r_fail:g})"
    return "no data"


def _rpm_at(fs: FamilySummary, r: float) -> float:
    return rad_s_to_rpm(r * fs.omega1_min) if math.isfinite(r) else math.nan


def _name(fs: FamilySummary) -> str:
    return f"{fs.linkage} {fs.mechanism}"


def linkage_rows(points: Sequence[Point]) -> list[list[str]]:
    """Data of each linkage (from the stored scene parameters)."""
    seen: dict[str, Point] = {}
    pay: dict[str, float] = {}
    for p in points:
        seen.setdefault(p.linkage, p)
        if p.mass_model == "tip":
            pay[p.linkage] = p.spec.mass_model.payload
    rows = []
    for name, p in seen.items():
        lk = p.spec.linkage
        s = lk.sections[0]
        ground = math.dist(lk.crank_pivot, lk.follower_pivot)
        rows.append([name, f"{1e3 * lk.crank:.1f}", f"{1e3 * lk.coupler:.1f}", f"{1e3 * lk.follower:.1f}",
                     f"{1e3 * ground:.1f}", f"{1e3 * lk.extender:.1f}", f"{math.degrees(lk.coupler_angle):.0f}",
                     f"{s.youngs_modulus / 1e9:.1f}", f"{1e6 * s.area:.2f}", f"{1e12 * s.second_moment:.1f}",
                     f"{s.density:.0f}", f"{pay.get(name, math.nan):.3f}"])
    return rows


def answer_rows(ref: Sequence[FamilySummary]) -> list[list[str]]:
    rows = []
    for fs in ref:
        s0 = fs.slots[0] if fs.slots else None
        floor = f"{pct(s0.errors.history, '.2f')} ({s0.r:g})" if s0 is not None and s0.ok else "-"
        rows.append([_name(fs), fs.mass_model, f"{fs.f1_range_hz[0]:.1f}-{fs.f1_range_hz[1]:.1f}",
                     f"{_rpm_at(fs, 1.0):.0f}", floor, limit_text(fs, "peak", 0.05), limit_text(fs, "peak", 0.10),
                     limit_text(fs, "history", 0.05), limit_text(fs, "history", 0.10)])
    return rows


def _crossed(ref: Sequence[FamilySummary], kind: str, tol: float) -> list[FamilySummary]:
    return [fs for fs in ref if fs.limits[(kind, tol)].status == "crossed"]


def plain_answer(f: Answer) -> list[str]:
    """Sentences from the answer's findings: the range of the limits over the families, per mass model."""
    def low(key: tuple[str, float]) -> str:
        lim = f.ranges[key].low.limits[key]
        return f"{f3(lim.r_limit)} (+{f3(lim.step)})"

    out = []
    if f.complete:
        out += [f"**In one line: on every four-bar and mass model tested (2 % damping), the quasi-static "
                f"peak deflection is within 5 % of the dynamic steady state up to r = {low(('peak', 0.05))} "
                f"and within 10 % up to r = {low(('peak', 0.10))}; the whole deflection history (shape "
                f"and phase) within 5 % up to r = {low(('history', 0.05))} and within 10 % up to "
                f"r = {low(('history', 0.10))}.** Per mass model and linkage below.", ""]
        verdict = ("in r, what matters is where the mass sits (the harmonic content of its inertia loads), "
                   "not the size or stiffness of the linkage" if f.within_mass_model < f.between_mass_models else
                   "the linkage matters as much as the mass model")
        out += [f"The 10 % history limit differs by {f.between_mass_models:.3f} between the mass models "
                f"(means over the linkages) and by at most {f.within_mass_model:.3f} between the linkages of one "
                f"mass model: {verdict}.", ""]
    what = {"peak": "peak deflection |d| of P", "history": "whole deflection history"}
    for (kind, tol), rg in f.ranges.items():
        out.append(
            f"* {what[kind]} within {100 * tol:g} %: r up to **{f3(rg.low.limits[(kind, tol)].r_limit)}** "
            f"({_name(rg.low)}, {rg.low.mass_model}) ... **{f3(rg.high.limits[(kind, tol)].r_limit)}** "
            f"({_name(rg.high)}, {rg.high.mass_model}) over the {rg.families} families with a crossing (first "
            f"crossings: the last passing grid ratio); largest grid step to the first failing ratio {f3(rg.step)}.")
    if f.shifts:
        out.append(f"* Discretization: rerunning the {len(f.shifts)} bracketing pairs with 2x elements and 2x steps "
                   f"moves a crossing by at most {max(f.shifts):.4f} (median {float(np.median(f.shifts)):.4f})"
                   + ("; the uncertainty is the r-grid spacing." if max(f.shifts) < 0.001 else "."))
    if f.history10:
        out.append("* Whole history within 10 %, per mass model (min-max over the linkages): " + "; ".join(
            f"{m} {f3(lo)}-{f3(hi)}" for m, (lo, hi) in f.history10.items()) + ".")
    return out


def rule_rows(ref: Sequence[FamilySummary]) -> list[list[str]]:
    rows = []
    for fs in ref:
        spec = " ".join(f"{a:.2f}" for a in fs.spectrum[:6])
        dyn10 = fs.limits[("history", 0.10)].r_limit
        dyn5 = fs.limits[("history", 0.05)].r_limit
        rows.append([_name(fs), fs.mass_model, spec, str(fs.k_significant[0.01]), str(fs.k_significant[0.05]),
                     f3(fs.one_mode[("history", 0.05)]), f3(dyn5), f3(fs.one_mode[("history", 0.10)]), f3(dyn10),
                     f3(fs.k_significant[0.01] * dyn10), f3(fs.k_significant[0.05] * dyn10),
                     f"{fs.f1_range_hz[1] / fs.f1_range_hz[0]:.2f}"])
    return rows


def rule_text(ref: Sequence[FamilySummary]) -> list[str]:
    """Generated verdict on the harmonic rule and the one-mode estimate."""
    out = []
    for kind in ("history", "peak"):
        for tol in TOLERANCES:
            pairs = [(fs, fs.one_mode[(kind, tol)], fs.limits[(kind, tol)].r_limit) for fs in _crossed(ref, kind, tol)]
            if not pairs:
                continue
            ratio = [d / p for _, p, d in pairs if p > 0]
            within = [abs(x - 1) <= 0.25 for x in ratio]
            worst = max(pairs, key=lambda t: abs(math.log(t[2] / t[1])) if t[1] > 0 else 0)
            out.append(f"* {kind} error {100 * tol:g} %: dynamic limit / one-mode prediction = "
                       f"{min(ratio):.2f} ... {max(ratio):.2f} (median {float(np.median(ratio)):.2f}); within "
                       f"±25 % for {sum(within)} of {len(pairs)} families; worst {_name(worst[0])} "
                       f"{worst[0].mass_model} (predicted {f3(worst[1])}, dynamic {f3(worst[2])}).")
    amp = []
    for fs in ref:
        qs = next((sl.point.qs for sl in fs.slots if sl.point.qs is not None), None)
        for sl in fs.slots:
            if sl.ok and sl.r >= 0.2 and qs is not None:
                pred = one_mode_curves(qs, np.array([sl.r]), fs.damping)["amplification"][0]
                amp.append(sl.errors.amplification / pred)
    if amp:
        amp_a = np.array(amp)
        out.append(f"* Beyond r = 0.2 ({len(amp)} solved scenes) the dynamic amplification / one-mode "
                   f"amplification is {amp_a.min():.2f} ... {amp_a.max():.2f} (median {np.median(amp_a):.2f}; "
                   f"{int(np.sum(np.abs(amp_a - 1) <= 0.25))} within ±25 %).")
    fams = _crossed(ref, "history", 0.10)
    for frac in (0.01, 0.05):
        c = [fs.k_significant[frac] * fs.limits[("history", 0.10)].r_limit for fs in fams]
        ks = [fs.k_significant[frac] for fs in fams]
        if c:
            out.append(f"* Rule 'k_sig r <= c' with k_sig at {100 * frac:g} % of the largest load harmonic: the "
                       f"implied c for the 10 % history limit spans {min(c):.2f} ... {max(c):.2f} "
                       f"(max/min {max(c) / min(c):.1f}); k_sig = {min(ks)} ... {max(ks)}.")
    return out


def _ratio(x: float) -> str:
    return f"{x:.3f}" if math.isfinite(x) else "-"


def claims_rows(c: Claims) -> tuple[list[list[str]], list[list[str]]]:
    """(doubling rows, cognate rows) of the claims' findings."""
    dbl = [[_name(fs), fs.mass_model, f"{a.r:.3f} / {b.r:.3f}", mm(a.qs_peak), mm(b.qs_peak),
            f"{peak_ratio(b.qs_peak, a.qs_peak):.3f}", mm(a.dyn_peak), mm(b.dyn_peak),
            _ratio(peak_ratio(b.dyn_peak, a.dyn_peak)), f"{pct(a.error, '.0f')} / {pct(b.error, '.0f')}",
            "; ".join(f"dyn. failed ({x.failure})" for x in (a, b) if x.failure is not None)]
           for fs, a, b in c.doubling]
    cog = [[fs.mass_model, f"{s.rpm:.0f}", mm(s.qs_peak), mm(k.qs_peak), f"{peak_ratio(k.qs_peak, s.qs_peak):.3f}",
            mm(s.dyn_peak), mm(k.dyn_peak), _ratio(peak_ratio(k.dyn_peak, s.dyn_peak))] for fs, s, k in c.cognate]
    return dbl, cog


def claims_text(c: Claims) -> list[str]:
    """Sentences on the two thesis claims, from their findings."""
    qs = [peak_ratio(b.qs_peak, a.qs_peak) for _, a, b in c.doubling]
    dyn = [(peak_ratio(b.dyn_peak, a.dyn_peak), fs) for fs, a, b in c.doubling]
    dyn = [(x, fs) for x, fs in dyn if math.isfinite(x)]
    err = [(a.error, fs) for fs, a, _ in c.doubling if math.isfinite(a.error)]
    out = []
    if dyn:
        lo, hi = min(dyn, key=lambda t: t[0]), max(dyn, key=lambda t: t[0])
        out += ["", f"Quasi-statically the 400/300 rpm ratio is {min(qs):.3f} ... {max(qs):.3f} for every mass "
                f"model; dynamically it is {lo[0]:.2f} ({_name(lo[1])}, {lo[1].mass_model}) ... {hi[0]:.2f} "
                f"({_name(hi[1])}, {hi[1].mass_model})"
                + (": 'doubles' is neither the quasi-static answer nor a general dynamic one; it depends on "
                   "where 300 and 400 rpm fall relative to the resonances of the crank harmonics."
                   if hi[0] - lo[0] > 0.3 else ".")]
    if err:
        lo, hi = min(err, key=lambda t: t[0]), max(err, key=lambda t: t[0])
        near = [f"{_name(f)} {f.mass_model}" for e, f in err if e < 0.10]
        out += ["", f"At the thesis's own 300 rpm the quasi-static history error is {pct(lo[0], '.0f')} "
                f"({_name(lo[1])}, {lo[1].mass_model}) ... {pct(hi[0], '.0f')} ({_name(hi[1])}, "
                f"{hi[1].mass_model}); within 10 %: {', '.join(near) if near else 'none'}."]
    return out


def cognate_text(c: Claims) -> list[str]:
    """The sentence on the cognate claim, from its findings."""
    qs = [x for x in (peak_ratio(k.qs_peak, s.qs_peak) for _, s, k in c.cognate) if math.isfinite(x)]
    dyn = [(peak_ratio(k.dyn_peak, s.dyn_peak), fs, s.rpm) for fs, s, k in c.cognate]
    dyn = [t for t in dyn if math.isfinite(t[0])]
    if not qs or not dyn:
        return []
    same = [f"{fs.mass_model} at {rpm:.0f} rpm ({v:.3f})" for v, fs, rpm in dyn if abs(v - 1.0) < 0.1]
    return ["", f"Cognate / source peak: quasi-static {min(qs):.3f} ... {max(qs):.3f}, dynamic "
            f"{min(v for v, _, _ in dyn):.3f} ... {max(v for v, _, _ in dyn):.3f}. The claim holds in "
            f"{len(dyn) - len(same)} of {len(dyn)} solved comparisons"
            + (f"; the peaks agree within 10 % dynamically for {', '.join(same)}." if same else ".")]


def variant_rows(summaries: Sequence[FamilySummary]) -> list[list[str]]:
    groups: dict[tuple, list[FamilySummary]] = {}
    for fs in summaries:
        groups.setdefault((fs.linkage, fs.mechanism, fs.mass_model), []).append(fs)
    rows = []
    for fams in groups.values():
        if len(fams) < 2:
            continue
        for fs in sorted(fams, key=lambda f: (f.direction, f.damping)):
            errs = {round(s.r, 6): s for s in fs.slots}
            cells = [pct(s.errors.history, ".1f") if s is not None and s.ok else ("failed" if s else "-")
                     for s in (errs.get(r) for r in (0.1, 0.25, 0.5))]
            rows.append([_name(fs), fs.mass_model, f"{100 * fs.damping:g} %", fs.direction,
                         limit_text(fs, "history", 0.05), limit_text(fs, "history", 0.10), *cells])
    return rows


def failure_lines(summaries: Sequence[FamilySummary]) -> tuple[list[str], int, int, int]:
    """(lines, failed slots, retried slots, solved by retry)."""
    lines, failed, retried, rescued = [], 0, 0, 0
    for fs in summaries:
        for s in (*fs.slots, *fs.rpm_points):
            retried += s.retried
            rescued += s.retried and s.ok
            if not s.ok:
                failed += 1
                p = s.point
                msg = p.message.split(" (time=")[0].split(". Likely cause")[0].split(" [")[0][:110]
                extra = f" (retry with {p.steps_per_cycle} steps/cycle also failed)" if s.retried else ""
                speed = f"r = {p.r:.3g}" + (f" ({p.spec.speed.value:g} rpm)" if p.speed_kind == "rpm" else "")
                lines.append(f"* {_name(fs)} {fs.mass_model}, zeta {100 * fs.damping:g} %, {fs.direction}, "
                             f"{speed}: {p.stage} {p.error_type}, {p.failure_class}{extra}: {msg}")
    return lines, failed, retried, rescued


def busy_seconds(starts: Sequence[str], ends: Sequence[str], longest_s: float) -> float:
    """Elapsed compute time [s] from ISO-8601 run starts and scene finishes: the sum of the gaps between
    consecutive events that end with a scene finish and are not longer than the slowest scene
    ``longest_s`` [s] (a longer gap has no scene running through it: idle time between runs; a run
    that computed nothing adds nothing)."""
    ev = sorted([(datetime.fromisoformat(x).timestamp(), 0) for x in starts]
                + [(datetime.fromisoformat(x).timestamp(), 1) for x in ends])
    return float(sum(b[0] - a[0] for a, b in zip(ev, ev[1:]) if b[1] == 1 and b[0] - a[0] <= longest_s + 1.0))


def render_section(points: Sequence[Point], summaries: Sequence[FamilySummary], *, files: Sequence[Path],
                   refine_file: Path, figures: Sequence[Path], readme: Path, configs: Sequence[Path]) -> str:
    """The whole Markdown section (without markers): header and setup, the answer, the harmonic rule,
    the thesis's claims, damping and direction, failures, run time, figures."""
    rel = readme.resolve().parent

    def link(p: Path) -> str:
        return os.path.relpath(p.resolve(), rel)

    ref_groups = reference(summaries)
    ref = [fs for fams in ref_groups.values() for fs in fams]
    L = _setup_part(points, files, refine_file, configs, link)
    L += ["", "### The answer", ""] + plain_answer(answer(ref))
    L += _families_part(ref) + _rule_part(ref) + _claims_part(summaries) + _variants_part(summaries)
    L += _failures_part(summaries) + _run_time_part(points, files, refine_file)
    L += ["", "### Figures", ""] + [f"![{p.stem}]({link(p)})" for p in figures]
    return "\n".join(L) + "\n"


def _lumps_text(points: Sequence[Point]) -> str:
    """How many lumps the lumped models used (from the stored scenes)."""
    n = sorted({p.spec.mass_model.lumps for p in points if p.mass_model in ("extender", "distributed")})
    return " or ".join(str(k) for k in n) or "-"


def _setup_part(points: Sequence[Point], files: Sequence[Path], refine_file: Path, configs: Sequence[Path],
                link: Callable[[Path], str]) -> list[str]:
    lumps = _lumps_text([p for p in points if not p.refined])
    base = next((p for p in points if not p.refined), None)
    dyn = dict(base.spec.dynamic) if base else {}
    dyn.pop("damping_ratio", None)
    L: list[str] = ["## Validity map: when does the quasi-static (instantaneous-structure) assumption hold?", ""]
    L += ["Regenerate (resumable; runs the campaigns, retries, refinement scenes, figures and this section):",
          "", "    ked study validity", "",
          "Configs: " + ", ".join(f"`{link(c)}`" for c in configs) + ". Results: "
          + ", ".join(f"`{link(f)}`" for f in (*files, refine_file) if f.exists()) + ".", ""]
    L += ["**Setup.** Crank speed as r = Omega / omega1_min (omega1_min: lowest first natural frequency of the "
          "frozen structure over the cycle, same mass model). Reference damping ratio "
          f"{100 * (base.damping if base else math.nan):g} % (stiffness-proportional, at the mean first "
          "frequency), crank ccw. Dynamic model (Exudyn, pinned): "
          + ", ".join(f"{k} = {v}" for k, v in sorted(dyn.items()))
          + f"; scenes below r = {RETRY_MAX_RATIO:g} whose Newton iteration failed are retried once with "
          f"{RETRY_STEP_FACTOR}x the steps per cycle. "
          "Mass models: tip (payload at P, massless links), joints (half of each link's mass at each end), "
          f"extender (extender mass in {lumps} lumps), distributed (quasi-static: {lumps} lumps per link; dynamic: the "
          "beams' consistent mass).", ""]
    L += ["Errors of the quasi-static deflection d = (dx, dy) of the coupler point P against the dynamic "
          "periodic steady state: **peak error** |max|d_qs| - max|d_dyn|| / max|d_dyn| (what the brief "
          "calls the peak deflection) and **history error** max|d_qs - d_dyn| / max|d_dyn| (whole cycle, "
          "amplitude and phase). Limit = the first crossing of the tolerance walking up the r grid, stated as "
          "the last grid ratio below which every grid scene solved and stayed under the tolerance (**r** "
          "(+step): the next grid ratio, r + step, did not). Never interpolated: a resonance peak between two "
          "grid ratios can cross the tolerance anywhere there, so the limit is known to one grid step. For "
          "reference the value interpolated linearly between the bracketing ratios is given, and 'fine' is that "
          "interpolated crossing when the two bracketing scenes are rerun with twice the elements per link and "
          "twice the steps per cycle (the discretization's share of the uncertainty).", ""]
    L += ["Linkages (all links the same section; lengths in mm, E in GPa, A in mm^2, I in mm^4, rho in "
          "kg/m^3, tip payload in kg):", ""]
    L += table(["linkage", "crank", "coupler", "follower", "ground", "extender", "coupler angle [deg]", "E", "A",
                 "I", "rho", "tip payload"], linkage_rows([p for p in points if not p.refined]))
    return L


def _families_part(ref: Sequence[FamilySummary]) -> list[str]:
    L = ["", "Per family (f1: first frozen frequency over the cycle, min-max; rpm at r = 1; the error at the "
          "smallest ratio is the floor that is not dynamics: mass discretization of the quasi-static model, "
          "geometric nonlinearity, steady-state tolerance):", ""]
    return L + table(["linkage", "mass model", "f1 [Hz]", "rpm at r=1", "history error at smallest r", "peak 5 %",
                      "peak 10 %", "history 5 %", "history 10 %"], answer_rows(ref))


def _rule_part(ref: Sequence[FamilySummary]) -> list[str]:
    crossings = [lim.r_limit for fs in ref for lim in fs.limits.values() if lim.status == "crossed"]
    beyond = max(crossings, default=math.nan)
    L = ["", "### Does a harmonic rule explain it?", "",
         "Harmonic content of the quasi-static inertia loads (all nodes, amplitudes of crank harmonics 1-6 "
         "normalized by the largest), k_sig = highest harmonic above 1 % / 5 % of the largest, the one-mode "
         "estimate's limit (each harmonic k of the quasi-static history amplified by "
         "1/(1 - (k r)^2 + 2 i zeta k r) with omega1 = omega1_min) and the dynamic limit (history error), "
         "and the implied fraction c = k_sig * r_lim(10 %):", ""]
    L += table(["linkage", "mass model", "load harmonics 1-6", "k_sig 1 %", "k_sig 5 %", "one-mode 5 %",
                 "dynamic 5 %", "one-mode 10 %", "dynamic 10 %", "c (1 %)", "c (5 %)", "f1 max/min"],
                rule_rows(ref))
    L += [""] + rule_text(ref)
    L += ["", "Reading: the one-mode estimate is the harmonic rule made quantitative (every crank harmonic of "
          "the quasi-static deflection amplified as a single-degree-of-freedom oscillator at omega1_min). "
          "Where the quasi-static answer is still usable (errors of 5-10 %) it predicts the dynamic limit of the "
          "whole-history error well, because there the error is the response of the first mode to the highest "
          "significant load harmonics. The crude form 'k_sig r below a fixed fraction c' needs a c that "
          "depends on how fast the load spectrum decays, so it is only a conservative bound (use the smallest c "
          "above). The estimate fails (i) for the peak-only error, which is not monotonic: the dynamic and "
          "quasi-static peaks occur at different crank angles and can match by chance (dips in the dashed "
          f"lines of the error figure), and (ii) beyond the limits (r > {beyond:.2g}), where omega1 varies over the "
          "cycle (f1 max/min up to the value in the table), the resonances k r = 1 are smeared over the "
          "range of omega1, higher modes and the geometric nonlinearity of large deflections matter, and "
          "the dynamic model itself often has no periodic steady state."]
    return L


def _claims_part(summaries: Sequence[FamilySummary]) -> list[str]:
    found = claims(summaries)
    dbl, cog = claims_rows(found)
    L: list[str] = []
    if dbl:
        L += ["", "### The thesis's claims, checked with dynamics", ""]
        L += ["'The deflection doubles for +100 rpm (300 -> 400 rpm)': peak |d| of P [mm]; quasi-static "
              "ratios are (4/3)^2 by construction:", ""]
        L += table(["linkage", "mass model", "r at 300 / 400 rpm", "qs 300", "qs 400", "qs ratio", "dyn 300",
                     "dyn 400", "dyn ratio", "history error 300 / 400", "note"], dbl)
    L += claims_text(found)
    if cog:
        L += ["", "'The cognate does not share the source's KED deflection': peak |d| of P [mm] at the same "
              "crank speed:", ""]
        L += table(["mass model", "rpm", "source qs", "cognate qs", "qs cognate/source", "source dyn",
                     "cognate dyn", "dyn cognate/source"], cog)
    L += cognate_text(found)
    return L


def _variants_part(summaries: Sequence[FamilySummary]) -> list[str]:
    var = variant_rows(summaries)
    return ["", "### Damping and crank direction", ""] + table(
        ["linkage", "mass model", "damping", "direction", "history 5 %", "history 10 %", "error r=0.1",
         "error r=0.25", "error r=0.5"], var) if var else []


def _failures_part(summaries: Sequence[FamilySummary]) -> list[str]:
    lines, failed, retried, rescued = failure_lines(summaries)
    return ["", "### Failures of the dynamic model (recorded in the HDF5 files)", "",
            f"{failed} grid slots have no dynamic steady state; {retried} slots were retried with "
            f"{RETRY_STEP_FACTOR}x the steps per cycle, {rescued} of them solved by the retry "
            "(open markers in the figures).", "", *lines]


def _run_time_part(points: Sequence[Point], files: Sequence[Path], refine_file: Path) -> list[str]:
    L = ["", "### Run time", ""]
    rows = []
    for f in (*files, refine_file):
        pts = [p for p in points if p.source == f.name]
        if pts:
            rows.append([f"`{f.name}`", str(len(pts)), str(sum(p.ok for p in pts)),
                         f"{sum(p.wall_s for p in pts):.0f}", f"{max(p.wall_s for p in pts):.0f}"])
    L += table(["file", "scenes", "solved", "sum of scene wall times [s]", "slowest scene [s]"], rows)
    starts = [t for f in (*files, refine_file) if f.exists() for t in run_starts(f)]
    ends = [p.finished_utc for p in points if p.finished_utc]
    if starts and ends:
        busy = busy_seconds(starts, ends, max(p.wall_s for p in points))
        L += ["", f"Elapsed compute time of the stored runs: {busy / 60:.1f} min ({len(points)} scenes; "
              "from the runs' start times and the scenes' finish "
              "times, idle gaps longer than the slowest scene left out). Tests: "
              "`pytest tests/test_study_validity.py -m 'not slow'` runs the whole pipeline on a tiny campaign; "
              "`pytest tests/test_study_validity.py -m slow` checks that the committed files verify and that "
              "this section is exactly what they give."]
    return L

