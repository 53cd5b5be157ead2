"""The atlas's README section and figures from the stored atlas file only: load -> analyse
(:func:`ked_research.atlas.findings.analyse`) -> figures -> markdown, which formats the findings only (the two
coupler curves are recomputed: two scenes, the atlas stores no histories)."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from compare import solvers
from compare.execute import frame, solve_one
from compare.markdown import median_range, num, table
from compare.sections import write_section
from ked_quasi.kinematics import coupler_point
from ked_quasi.massmodel import MASS_MODELS
from ked_research.atlas import calibration as cal
from ked_research.atlas import figures
from ked_research.atlas import findings as fd
from ked_research.atlas import store as atlas_store
from ked_research.atlas.analysis import crossed, first_crossings
from ked_research.atlas.compute import RATIOS, spec_of, xy
from ked_research.atlas.generate import candidate
from ked_research.atlas.threshold import TABLE, TARGET

SECTION = "atlas"
DESIGN_FEATURES = {"crank_ratio": "crank / ground", "coupler_ratio": "coupler / ground",
                   "follower_ratio": "follower / ground", "extender_ratio": "extender / coupler",
                   "slenderness": "ground slenderness (ground / radius of gyration)"}
"""Design parameters of /linkages -> their names in tables and figures."""
FIGURES = ("atlas_limits.png", "atlas_features.png", "atlas_prediction.png", "atlas_map.png", "atlas_confirm.png",
           "atlas_coupler_curves.png", "atlas_threshold.png")


def features(fam: dict[str, np.ndarray], links: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per family: the features that may move its limit (design parameters joined from /linkages)."""
    row = {int(i): j for j, i in enumerate(links["index"])}
    idx = np.array([row[int(i)] for i in fam["linkage"]])
    out = {"k_sig (1 %)": fam["k_sig_1"], "k_sig (5 %)": fam["k_sig_5"],
           "f1 max / f1 min": fam["f1_max_hz"] / fam["f1_min_hz"],
           "min transmission angle [deg]": fam["min_transmission_deg"],
           "cognate (1) / source (0)": (np.asarray(fam["mechanism"], dtype=object) == "cognate").astype(float)}
    out.update({label: np.asarray(links[name], float)[idx] for name, label in DESIGN_FEATURES.items()})
    out["abs(coupler angle) [deg]"] = np.abs(np.asarray(links["coupler_angle_deg"], float)[idx])
    carried = (np.asarray(fam["mass_model"], dtype=object) == "tip") | np.asarray(links["payload_all"], bool)[idx]
    out["payload at P / link mass"] = np.where(carried, np.asarray(links["payload_ratio"], float)[idx], 0.0)
    return out


def distribution_table(rows: tuple[fd.Distribution, ...]) -> list[str]:
    return table(("mass model", "families", "r* 5 %: median [P10-P90]", "r* 10 %: median [P10-P90]", "min-max (10 %)",
                  "10 % status: crossed / above grid / below grid / linear unstable first / failed"),
                 [[d.mass_model, str(d.families), median_range(d.r5), median_range(d.r10),
                   f"{d.r10_range[0]:.3f}-{d.r10_range[1]:.3f}" if d.r10_range else "-",
                   " / ".join(str(d.status[k]) for k in ("crossed", "above_grid", "below_grid", "failure", "no_data"))]
                  for d in rows], dense=True)


def flags_text(f: fd.Flags) -> str:
    """How often the linear model's answer leaves its small-deflection range at or below the 10 % limit."""
    return (f"Linear model's large-deflection / large-rotation flags (`ked_quasi.limits`): on {f.anywhere} "
            f"families somewhere on the computed sweep, on {f.early} at or below their r* (10 %). Largest "
            f"Floquet |mu| at or below r* (10 %): median {f.mu_median:.3f}, max {f.mu_max:.3f} "
            f"({'all stable' if f.mu_max < 1 else 'some unstable'}).")


def correlation_table(rho: dict[str, tuple[float, ...]]) -> list[str]:
    return table(("feature", *MASS_MODELS, "all"), [[name, *(f"{x:+.2f}" for x in r)] for name, r in rho.items()],
                 dense=True)


def prediction_text(p: fd.Predictions) -> list[str]:
    L = [f"* one-mode estimate of the {100 * tol:g} % limit: {ok:.0%} of {n} families within +-25 % "
         f"(median ratio predicted/atlas {ratio:.3f})." for tol, (ok, n, ratio) in p.one_mode.items()]
    L.append(f"* rule k_sig r <= c (k_sig at 1 %), one c = {p.c['all']:.3f} for all: {p.within_one_c:.0%} within "
             f"+-25 %; c per mass model ({', '.join(f'{k} {v:.3f}' for k, v in p.c.items() if k != 'all')}): "
             f"{p.within_per_mass_model:.0%} within +-25 %.")
    return L


def worst_table(rows: tuple[fd.Worst, ...]) -> list[str]:
    return table(("family", "r* 10 %", "one-mode", "rule", "k_sig 1 % / 5 %", "f1 max/min", "min transmission [deg]"),
                 [[w.family, f"{w.r10:.3f}", f"{w.one_mode:.3f}", f"{w.rule:.3f}", f"{w.k_sig[0]} / {w.k_sig[1]}",
                   f"{w.f1_ratio:.2f}", f"{w.min_transmission_deg:.0f}"] for w in rows], dense=True)


def tier_table(rows: tuple[tuple[fd.TierLimits, tuple[float, ...]], ...]) -> list[str]:
    """Tier limits with, beside each, the median grid step of the first crossings behind it."""
    def cells(t: fd.TierLimits, steps: tuple[float, ...]) -> list[str]:
        return [f"{v:.3f} - {s:.3f} (step {num(h, '.3f')})" if math.isfinite(v) else "-" for (v, s), h in zip((
            (t.quasi_static_r5, t.quasi_static_r5_spread), (t.quasi_static_r10, t.quasi_static_r10_spread),
            (t.linear_r5, t.linear_r5_spread), (t.linear_r10, t.linear_r10_spread)), steps)]

    return table(("mass model", "quasi-static 5 %", "quasi-static 10 %", "linear 5 %", "linear 10 %",
                  "families / confirmed"), [[t.mass_model, *cells(t, steps), f"{t.families} / {t.confirmed_families}"]
                                            for t, steps in rows], dense=True)


def linear_limit_table(rows: tuple[fd.LinearLimits, ...]) -> list[str]:
    """The linear model's own limits against Exudyn per mass model (confirmed families)."""
    return table(("mass model", "tolerance", "families", "crossed: median [P10-P90] (median step)",
                  "not reached up to r (median lower bound)", "below the smallest / Exudyn failed first"),
                 [[x.mass_model, f"{100 * x.tolerance:g} %", str(x.families),
                   f"{x.crossed.size}: {median_range(x.crossed)} ({num(x.step, '.3f')})",
                   f"{x.not_reached} ({x.not_reached_median:.3f})" if x.not_reached else "0",
                   f"{x.below} / {x.failed}"]
                  for x in rows], dense=True)


def headline(h: fd.Headline, strata: dict[str, cal.Margins] | None = None) -> str:
    """The section's answer in a few sentences."""
    text = (f"**In short:** over {h.families} families the quasi-static coupler-point history stays within 10 % of "
            f"the linear KED model up to r* = {h.r10_median:.3f} (median; 10-90 % of the families: "
            f"{h.r10_p10:.3f}-{h.r10_p90:.3f}; first crossings on the atlas grid, median "
            f"step {h.r10_step_median:.3f}) and within 5 % up to "
            f"{h.r5_median:.3f}. The medians of the four mass models differ by "
            f"{h.mass_model_spread:.3f}, the linkages of one mass model by up to {h.widest:.3f} (10-90 %): strongest "
            "rank correlations with r* "
            + ", ".join(f"{k} ({rho:+.2f})" for k, rho in h.correlations)
            + f". The one-mode estimate predicts r* within +-25 % for {h.one_mode_within:.0%} of the families.")
    if strata:
        granted = [k for k, m in strata.items() if m.holds_below > 0]
        margins = ", ".join(f"{k.split('/', 1)[1]} {strata[k].holds_below:g}" for k in granted) or "none"
        worst = max(m.stats.unsafe.high95 for k, m in strata.items())
        text += (f" At the threshold (Exudyn-confirmed scenes within +-25 % of their family's 10 % limit), `ked check` "
                 f"calibrates its quasi-static call per stratum (linkage kind x mass model x mechanism, "
                 f"{min(m.stats.n for m in strata.values())}-{max(m.stats.n for m in strata.values())} scenes each): "
                 f"{len(granted)} of the {len(strata)} four-bar strata grant the quasi-static tier from a prediction "
                 f"(margins {margins} "
                 f"x the tolerance), every stratum's unsafe-call rate with a 95 % upper bound of at most "
                 f"{worst:.1%} (table below); a stratum without enough data grants none and says so (the "
                 "slider-crank strata: their own atlas and table).")
    return text


def _ci(x: cal.Rate) -> str:
    """'k/n = rate [low-high]' of a binomial rate."""
    if x.n == 0:
        return "-"
    return f"{x.k}/{x.n} = {x.rate:.1%} [{x.low95:.1%}-{x.high95:.1%}]"


def strata_table(strata: dict[str, cal.Margins]) -> list[str]:
    """One row per stratum: its own margins and the calls they make on its threshold scenes."""
    rows = [[k, str(m.stats.n), f"{m.holds_below:g} / {m.fails_above:g}",
             "yes" if m.holds_below > 0 else ("no: fewer than " + str(cal.MIN_STRATUM) if m.stats.n < cal.MIN_STRATUM
                                              else "no: bound not met"),
             str(m.stats.quasi_static), f"{m.stats.borderline} ({m.stats.borderline_measured_fail})",
             str(m.stats.not_quasi_static), _ci(m.stats.unsafe), _ci(m.stats.overcautious),
             f"{m.ratio_q05:.3f}-{m.ratio_q95:.3f}"] for k, m in strata.items()]
    return table(("stratum", "scenes (Exudyn ok)", "holds below / fails above [x tol]", "grants quasi-static",
                  "quasi-static", "borderline (measured fail)", "not quasi-static", "unsafe [95 %]",
                  "over-cautious [95 %]", "measured / predicted, 5-95 % tolerance bounds"), rows, dense=True)


def threshold_text(t: fd.ThresholdFindings | None, strata: dict[str, cal.Margins] | None = None) -> list[str]:
    """The threshold calibration: counts, rates with intervals, the chosen margins, per stratum."""
    if t is None:
        return ["No threshold sample yet (`ked study atlas --threshold N`)."]
    mg = t.margins

    def row(name: str, s: cal.CallStats) -> list[str]:
        return [name, str(s.quasi_static), f"{s.borderline} ({s.borderline_measured_fail})", str(s.not_quasi_static),
                _ci(s.unsafe), _ci(s.overcautious), _ci(s.agreement)]

    L = [f"Stratified (`ked_research.atlas.threshold`): per mass model and mechanism ({t.strata_min}-"
         f"{t.strata_max} scenes each), families drawn from equal strata of their r* (10 %), one scene "
         f"each at r = f x r* with f uniform in [0.75, 1.25] (drawn: {t.factor_min:.3f}-{t.factor_max:.3f}; r* the "
         "interpolated value the file stores, which lies in its first-crossing bracket); quasi-static, linear and "
         "Exudyn (`DynamicSettings()` defaults: 4 elements per link, 720 steps per cycle, from the ramp): "
         f"{t.threshold_scenes} scenes, joined by the "
         f"{t.joined} scenes of the confirmed sample below that lie in the same band (at r = r*).", "",
         f"* {t.scenes} scenes, {t.exudyn_ok} with an Exudyn steady state, {t.scenes - t.exudyn_ok} failed (stored "
         "with their reasons, left out of the rates).",
         f"* Measured error (quasi-static vs Exudyn) over predicted (quasi-static vs linear): median "
         f"{t.ratio_median:.3f}, 5-95 %: {t.ratio_q05:.3f}-{t.ratio_q95:.3f}; "
         f"where the prediction is within +-20 % of the tolerance ({t.near} scenes) |measured - predicted| "
         f"median {t.near_diff_median:.4f}, max {t.near_diff_max:.4f}.",
         f"* Measured above the tolerance: {t.measured_fail} of {t.exudyn_ok}.", "",
         "The check's call at 10 % (unsafe: quasi-static called adequate, measured >= 10 %; over-cautious: not "
         "quasi-static, measured < 10 %; both over every scene with an Exudyn answer; agreement over the decisive "
         "calls; borderline calls, with how many measured >= 10 % in brackets, say: run `--confirm`):", "",
         *table(("rule", "quasi-static", "borderline (measured fail)", "not quasi-static", "unsafe [95 %]",
                 "over-cautious [95 %]", "agreement [95 %]"), [
             row("plain: e < 10 %, no margin, no linear-range gate (context)", mg.plain),
             row(f"pooled (context): e < {mg.holds_below:g} x 10 % and r below the linear lower band; borderline to "
                 f"{mg.fails_above:g} x", mg.stats)], dense=True), "",
         f"**Pooled margins** (every stratum together, context only: the check uses each stratum's own, below): "
         "quasi-static holds below "
         f"**{mg.holds_below:g} x** the tolerance, borderline up to **{mg.fails_above:g} x**, each the more cautious "
         f"of two criteria. Rate: the largest multiplier whose unsafe-call rate has a 95 % upper bound <= "
         f"{cal.MAX_UNSAFE_UPPER95:.0%} ({mg.holds_below_rate:g} x; "
         f"{'met' if mg.bound_met else 'NOT met: the prediction alone grants no quasi-static tier'}), and the "
         f"smallest >= 1 whose over-cautious predictions (e >= it, measured < 10 %) meet the same bound "
         f"({mg.fails_above_rate:g} x). Scatter: measured / predicted error of the {mg.n_near} scenes predicted "
         f"within +-20 % of the tolerance (all scenes when fewer than {cal.MIN_NEAR}), distribution-free 95 % / 95 % "
         f"tolerance bounds of its 5th and 95th percentiles: {mg.ratio_q05:.3f}-{mg.ratio_q95:.3f}, so a call at "
         f"1 / {mg.ratio_q95:.3f} = {mg.holds_below_scatter:g} x (at 1 / {mg.ratio_q05:.3f} = "
         f"{mg.fails_above_scatter:g} x) is right with at least 95 % probability, at 95 % confidence. With these "
         f"margins the unsafe calls' upper bound is {mg.stats.unsafe.high95:.1%}. The linear-range gate (r below "
         "the mass model's lower-band "
         f"linear limit) withheld the quasi-static tier from {t.gated} scenes the margin alone would have granted. "
         "The rule is `ked_research.atlas.calibration.calls`, which `ked check` mirrors."
         f" The {t.overcautious} over-cautious calls: {t.overcautious_flagged} where the linear solution carries a "
         f"large-deflection or large-rotation flag (of {t.flagged} such scenes), "
         f"{t.overcautious_gate} by the linear-range gate, {t.overcautious_prediction} by the prediction.", "",
         "**Per stratum** (what `ked check` uses; `ked_research.atlas.calibration.strata_margins`): "
         "each stratum's margins "
         "chosen by the same two criteria from its own scenes alone, so a stratum whose prediction is biased never "
         "hides behind the others; a stratum grants the quasi-static tier from a prediction only with at least "
         f"{cal.MAX_UNSAFE_UPPER95:.0%} as the 95 % upper bound of its unsafe calls and {cal.MIN_STRATUM} Exudyn "
         "answers (with no unsafe call the bound needs 122). The pooled margins above are context only.", "",
         *strata_table(strata or {})]
    if t.early is not None:
        below, early, between, unseen = t.early
        L += ["", f"First crossings, checked: {early} of the {below} threshold scenes below their "
              "family's interpolated r* already have a predicted error >= 10 %: "
              f"{between} between the last passing grid ratio and the interpolated value (the "
              "interpolation overstated the limit: why every atlas limit is the last passing grid ratio), "
              f"{unseen} at or below the last passing grid ratio (a crossing the atlas grid did not see)."]
    return L


def confirm_text(c: fd.ConfirmFindings | None) -> list[str]:
    if c is None:
        return ["No scene confirmed with Exudyn yet (`ked study atlas --confirm N`)."]
    st = c.linear_status
    L = [f"* {c.scenes} scenes ({c.families} families), {c.exudyn_ok} with an Exudyn "
         f"steady state, {c.scenes - c.exudyn_ok} failed; Exudyn wall time median {c.wall_median_s:.1f} s.",
         f"* Context only (most of these scenes are far from r*): the plain 10 % call (quasi-static vs linear) and "
         f"the reference (quasi-static vs Exudyn) agree on {c.agree}/{c.exudyn_ok} scenes, on "
         f"{c.agree_at}/{c.at} of those at r = r*; |difference of the two errors| median "
         f"{c.diff_median:.3f}, 90th percentile {c.diff_p90:.3f}.",
         f"* The linear model is within 5 % of Exudyn on {c.linear_within[0.05]:.0%} and within 10 % on "
         f"{c.linear_within[0.10]:.0%} of "
         f"the scenes (which reach {c.factor_max:g} x the quasi-static limit); its 10 % limit per "
         f"family: {st['crossed']} crossed, {st['above_grid']} not reached (lower bound: the largest confirmed r), "
         f"{st['below_grid']} already at the smallest, {st['failure']} ended by an Exudyn failure."]
    L += [f"* Exudyn failures: {k} ({v})" for k, v in c.failures]
    return L


def coupler_curve_data(atlas: Path, fam: dict[str, np.ndarray], seed: int) -> list[dict[str, Any]]:
    """Recompute the most and the least forgiving families (largest / smallest r10) at r = 0.1."""
    m = np.flatnonzero(crossed(fam, "r10"))
    out = []
    for label, i in (("most forgiving", m[np.argmax(fam["r10"][m])]), ("least forgiving", m[np.argmin(fam["r10"][m])])):
        lk = candidate(seed, int(fam["linkage"][i]))
        mm = next(x for x in lk.mass_models if x.name == fam["mass_model"][i])
        spec = spec_of(lk, str(fam["mechanism"][i]), mm, 0.1)
        fr = frame(spec)
        qs, lin = (solve_one(solvers.get(n), spec, fr.scene) for n in ("quasi_static", "linear"))
        rigid = np.asarray(coupler_point(fr.scene.fourbar, fr.scene.crank_angles))
        size = float(np.ptp(rigid, axis=0).max())
        mag = 0.15 * size / max(float(np.hypot(*xy(lin).T).max()), 1e-30)
        out.append({"title": f"{label}: {fd.family_name(fam, i)}, r* (10 %) = {fam['r10'][i]:.3f}; at r = 0.1",
                    "rigid": rigid, "quasi_static": xy(qs), "linear": xy(lin), "magnification": mag})
    return out


def sample_text(x: fd.SampleFindings) -> list[str]:
    rg = x.ranges

    def span(key: str) -> str:
        lo, hi = rg.get(key, (math.nan, math.nan))
        return f"{lo:g}-{hi:g}"

    return [f"**Sample** (`ked_research.atlas.generate`, seed {x.seed}): {x.accepted} linkages accepted of "
            f"{x.candidates} candidates drawn; {x.cognates} of them with a crank-drivable crossed Roberts cognate. "
            "Rejected, with their reasons stored in `/linkages`: " + "; ".join(f"{v} {k}" for k, v in x.rejected) + ".",
            "",
            f"Ranges: ground {span('ground_m')} m (log-uniform); crank/ground {span('crank_ratio')}, coupler/ground "
            f"{span('coupler_ratio')}, follower/ground {span('follower_ratio')} (uniform; Grashof crank-rockers with "
            f"margin {rg.get('grashof_margin')} of the ground); extender/coupler {span('extender_ratio')}, coupler "
            f"angle {span('coupler_angle_deg')} deg; branch open or crossed; steel or aluminium round rods and "
            f"rectangular bars (depth/width aspect {span('bar_aspect')}), ground slenderness ground / radius of "
            f"gyration {span('slenderness')} (log-uniform); payload at P {span('payload_ratio')} x the link mass "
            "(tip; the other mass models carry it on half the linkages); minimum transmission angle "
            f">= {rg.get('min_transmission_deg')} deg (nearer a toggle: rejected)."]


def load(atlas: Path) -> tuple[dict[str, Any], dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """(attributes, families with first-crossing limits, linkages, confirm) of the stored atlas."""
    info = atlas_store.attrs(atlas)
    fam, links, conf = (atlas_store.read(atlas, t) for t in ("families", "linkages", "confirm"))
    return info, first_crossings(fam, info.get("ratios", RATIOS)), links, conf


def threshold_of(atlas: Path) -> tuple[cal.ThresholdData | None, cal.Margins | None]:
    """The threshold sample and its chosen margins (None, None without one)."""
    if not atlas_store.read(atlas, TABLE):
        return None, None
    return cal.threshold_data(atlas), cal.threshold_margins(atlas)


def drawn_from(atlas: Path) -> str:
    """Where the Exudyn samples (confirm and threshold tables) were drawn: from every linkage of the atlas, or
    (when they were drawn before the atlas was extended) from its first K linkages: a sentence, or ""."""
    families = np.unique(atlas_store.read(atlas, "families").get("linkage", np.zeros(0, int)))
    sampled = [atlas_store.read(atlas, t).get("linkage", np.zeros(0, int)) for t in ("confirm", TABLE)]
    sampled = np.concatenate([np.asarray(x, int) for x in sampled])
    if not sampled.size or not families.size:
        return ""
    k = int(np.count_nonzero(families <= sampled.max()))
    if k >= families.size:
        return ""
    return (f"Both Exudyn samples below were drawn when the atlas held its first {k} of the {families.size} "
            "linkages (a random subset of the same seeded draws); `ked study atlas` redraws them from every "
            "linkage and confirms the new scenes with Exudyn.")


def lumping_text(atlas: Path) -> str:
    """Which lumping (lumps per link of the quasi-static answer, of the linear model's dynamics) made each table's
    extender and distributed scenes (file attribute ``lumps_by``; a table without an entry: the former 5)."""
    from ked_research.atlas.lumps import ATTR, LEGACY

    made = atlas_store.attrs(atlas).get(ATTR)
    made = made if isinstance(made, dict) else {}

    def says(table: str) -> str:
        m = made.get(table, LEGACY)
        dyn = m.get("dynamic_lumps")
        return f"{m.get('lumps')} lumps per link" + (f", the linear model's dynamics on {dyn}" if dyn else "")

    return ("**Lumping** of the extender and distributed scenes (the other mass models have no lumps): family sweeps "
            f"{says('families')}; Exudyn-confirmed samples {says('confirm')} (confirmed) and {says(TABLE)} "
            "(threshold). A table made with an older lumping is confirmed again by `ked study atlas` "
            "(`ked_research.atlas.reconfirm`); the family sweeps are recomputed only from a fresh atlas (`--fresh`).")


def slider_text(slider: Path, readme: Path) -> list[str]:
    """The slider atlas's part of the README section: what it holds and one row per slider stratum (count,
    unsafe, over-cautious, 95 % bounds, margins), from ``strata_margins`` of the slider atlas file."""
    from ked_research.atlas.slider_generate import RANGES

    fam, thr = atlas_store.read(slider, "families"), atlas_store.read(slider, TABLE)
    conf = atlas_store.read(slider, "confirm")
    links = atlas_store.read(slider, "linkages")
    n_link = int(np.sum(links["accepted"])) if "accepted" in links else 0
    cpu = float(np.nansum(fam.get("wall_s", []))) + float(np.nansum(np.concatenate(
        [np.asarray(t.get("dyn_wall_s", []), float) for t in (conf, thr)])))
    strata = cal.strata_margins(slider) if thr else {}
    rel = os.path.relpath(slider.resolve(), readme.resolve().parent)
    lo, hi = TARGET
    x = np.asarray(thr.get("qs_vs_linear", []), float) / 0.10
    aimed = int(np.sum((x >= lo) & (x <= hi)))
    r = RANGES
    return [
        "### Slider-crank strata (`ked_research.atlas.slider_generate`)", "",
        f"A separate atlas of {n_link} generated slider-cranks (`{rel}`, {slider.stat().st_size / 1e6:.1f} MB; "
        f"computed by `ked study atlas --slider-linkages {n_link}`, resumable): crank {r.crank_m[0]:g}-"
        f"{r.crank_m[1]:g} m and crank/rod {r.crank_rod_ratio[0]:g}-{r.crank_rod_ratio[1]:g} log-uniform, slider "
        f"offset {r.offset_ratio[0]:g}-{r.offset_ratio[1]:g} x rod, coupler point {r.coupler_point[0]:g}-"
        f"{r.coupler_point[1]:g} of the rod from the crank pin, steel or aluminium rods and bars of rod slenderness "
        f"{r.slenderness[0]:g}-{r.slenderness[1]:g}, the crank rigid in half of them, payload and slider mass "
        f"{r.payload_ratio[0]:g}-{r.payload_ratio[1]:g} x the link / rod mass; mass models tip, joints, distributed "
        f"({len(fam.get('linkage', []))} families, the same sweep, confirmed sample and threshold design as the "
        "four-bars, plus a third threshold draw aimed at predicted errors "
        f"{lo:g}-{hi:g} x the tolerance (`ked_research.atlas.threshold.select_targeted`); "
        "Exudyn with the same settings). "
        f"{len(thr.get('key', []))} threshold scenes ({aimed} predicted at {lo:g}-{hi:g} x 10 %), "
        f"{len(conf.get('key', []))} confirmed; solver time stored in the file {cpu / 60:.0f} CPU-min (family sweeps "
        "and Exudyn). Its margins are calibrated by the same code, per stratum:", "",
        *(strata_table(strata) if strata else ["No slider threshold sample yet: no slider stratum grants a tier."])]


def markdown(f: fd.AtlasFindings, atlas: Path, readme: Path, figs: dict[str, Path],
             slider: Path | None = None) -> str:
    """The README section from the findings (figure and atlas paths relative to the README); ``slider``: the
    slider atlas file, whose strata get their own table (:func:`slider_text`)."""
    rel = {k: os.path.relpath(v.resolve(), readme.resolve().parent) for k, v in figs.items()}
    strata = cal.strata_margins(atlas) if f.threshold is not None else {}
    info = f.info
    st = info.get("settings", {})
    L = ["## Atlas: the quasi-static limit over the design space", "", headline(f.headline, strata), "",
         "Regenerate (resumable; computes what is missing, then redraws): `ked study atlas --linkages N --confirm M "
         "--threshold T --threshold-top-up U`; after a change of the linear model the stored predictions are "
         "recomputed once (`ked_research.atlas.repredict`, the file attribute `predicted_by` names the code) "
         f"(stored: `{os.path.relpath(atlas.resolve(), readme.resolve().parent)}`, "
         f"{atlas.stat().st_size / 1e6:.1f} MB; figures `figures/atlas_*.png`).", "",
         *sample_text(f.sample), "", lumping_text(atlas), "",
         f"**Setup.** Every family (linkage x mechanism x mass model: {f.families} families) is swept over "
         f"r = Omega/omega1_min in {', '.join(f'{r:g}' for r in info.get('ratios', RATIOS))} (omega1_min: lowest "
         "first frozen natural frequency over the cycle), each scene a campaign scene solved by the registered "
         f"quasi-static and linear solvers (default settings, {st.get('damping_ratio', 0.02):g} damping, ccw, "
         f"{st.get('step_deg', 10):g} deg grid). Error: vector history error max|d_qs - d_lin| / max|d_lin| of the "
         "coupler point (`compare.metrics`), the dynamic part of the quasi-static error. A sweep stops after the "
         f"first r whose error reaches {st.get('stop_error', 0.2):g} (the limits are known by then). Limit r*: the "
         "first crossing of the tolerance walking up the grid, stated as the last grid ratio below it (never "
         "interpolated: a resonance peak between two grid ratios can cross the tolerance unseen, see the threshold "
         "calibration below); the crossing lies between r* and r* + step, the grid step there (median "
         f"{f.steps[0]:.3f} for 5 %, {f.steps[1]:.3f} for 10 %; largest {f.steps[2]:.3f}). The grid is not fine "
         "enough to see the narrow resonances of high crank "
         "harmonics (half-power width about 2 x damping x r, 0.006 at r = 0.15, below the grid step there); the "
         "threshold sample measures what this misses.", "",
         "### Distribution of the quasi-static limit", "", *distribution_table(f.distribution), "",
         flags_text(f.flags), "", f"![limits]({rel['limits']})", "",
         "### What moves it", "",
         "Spearman rank correlation of r* (10 %) with each feature, per mass model (k_sig: highest crank harmonic of "
         "the inertia loads above 1 % / 5 % of the largest; f1 max/min: variation of the first frozen frequency over "
         "the cycle):", "", *correlation_table(f.correlations), "",
         f"![features]({rel['features']})", "",
         f"![map]({rel['map']})", "",
         "### How well the one-mode estimate and the harmonic rule predict it", "",
         *prediction_text(f.predictions), "", "Worst one-mode predictions (10 %):", "", *worst_table(f.worst), "",
         f"![prediction]({rel['prediction']})", "",
         "### Tier limits (`ked_research.atlas.limits(mass_model)`, used by `ked check`)", "",
         "Median over the families - spread (median minus the 10th percentile); every family's limit a first "
         "crossing (the last passing ratio; beside it the median grid step to the first failing one). Quasi-static: "
         "the atlas; linear: its own limit against Exudyn from the confirmed sample (a family whose linear error "
         "never reached the tolerance counts with its largest confirmed r, a lower bound). The linear limits rest on "
         "the confirmed sample's coarse ratios (0.6 ... 3 x r*: steps near 0.1), so each is a lower bound known to "
         "that step; `ked check` counts the lower band (limit minus spread) against the linear model.", "",
         *tier_table(f.tiers), "",
         "### Calibration at the threshold (`ked check`'s quasi-static call)", "",
         *([drawn_from(atlas), ""] if drawn_from(atlas) else []),
         *threshold_text(f.threshold, strata), "", f"![threshold]({rel['threshold']})", "",
         *([*slider_text(slider, readme), ""] if slider is not None else []),
         "### Exudyn-confirmed sample (context: mostly far from the threshold)", "",
         "Stratified (`ked_research.atlas.confirm`): per mass model, families drawn from equal strata of their r* "
         "(10 %), "
         "each at r = 0.6, 1, 1.4, 2, 3 x r* (interpolated r*, capped at 0.5); quasi-static, linear and Exudyn "
         "(default settings). Four in five of these scenes sit at 0.6 r* or >= 1.4 r*, where the verdict is easy: "
         "the calibration above is the one at the threshold. The linear model's limits of the tier table come from "
         "these ratio walks (first crossings on the grid 0.6, 1, 1.4, 2, 3 x r*: coarse, steps stated).", "",
         *confirm_text(f.confirm), "",
         "The linear model's own limit (linear vs Exudyn history error) per confirmed family:", "",
         *(linear_limit_table(f.linear) if f.linear else []), "", f"![confirm]({rel['confirm']})", "",
         f"![coupler curves]({rel['coupler_curves']})"]
    return "\n".join(L) + "\n"


def write_report(atlas: Path, figures_dir: Path, readme: Path, slider: Path | None = None) -> dict[str, Any]:
    """Figures and the README section from the stored atlas (and the slider atlas file ``slider``, if any)."""
    info, fam, links, conf = load(atlas)
    thr, margins = threshold_of(atlas)
    feats = features(fam, links)
    found = fd.analyse(info, fam, links, conf, thr, margins, feats, np.asarray(info.get("ratios", RATIOS)))
    pick = {k: feats[k] for k in ("k_sig (1 %)", "f1 max / f1 min", "min transmission angle [deg]",
                                  "extender / coupler", "crank / ground", DESIGN_FEATURES["slenderness"])}
    figs = {"limits": figures.limits_histogram(fam, figures_dir / FIGURES[0]),
            "features": figures.features(fam, pick, figures_dir / FIGURES[1]),
            "prediction": figures.predictions(fam, found.predictions.rule, figures_dir / FIGURES[2]),
            "map": figures.design_map(fam, *_map_axes(found, feats), figures_dir / FIGURES[3]),
            "confirm": figures.confirm(conf, figures_dir / FIGURES[4]) if conf else figures_dir / FIGURES[4],
            "coupler_curves": figures.coupler_curves(coupler_curve_data(atlas, fam, int(info["seed"])),
                                                     figures_dir / FIGURES[5]),
            "threshold": figures.threshold(thr.e, thr.measured, thr.mass_model, thr.factor, margins.tolerance,
                                           margins.holds_below, margins.fails_above, figures_dir / FIGURES[6])
            if thr is not None and margins is not None else figures_dir / FIGURES[6]}
    write_section(readme, SECTION, markdown(found, atlas, readme, figs, slider))
    return {"figures": [str(p) for p in figs.values()], "readme": str(readme), "families": len(fam["linkage"]),
            "confirmed": len(conf.get("key", []))}


def _map_axes(found: fd.AtlasFindings, feats: dict[str, np.ndarray]) -> tuple[tuple[str, np.ndarray], ...]:
    """The two design parameters with the strongest rank correlation with r* (10 %) over the atlas."""
    names = [*DESIGN_FEATURES.values(), "abs(coupler angle) [deg]"]
    best = sorted(names, key=lambda n: -abs(np.nan_to_num(found.correlations[n][-1])))[:2]
    return tuple((n, feats[n]) for n in best)
