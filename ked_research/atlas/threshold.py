"""The threshold confirmation of the atlas: Exudyn where the check's decision is made.

Selection (:func:`select_threshold`, pure and seeded, in two independent draws of the same design whose
union is the sample): per stratum (mass model x mechanism, 8 strata, each draw split evenly),
the families whose quasi-static 10 % limit r10 was crossed on the atlas grid,
sorted by r10 and cut into equal chunks, one family drawn from each chunk; each drawn family gives one
scene at r = f x r10 with f drawn uniformly from [1 - :data:`BAND`, 1 + :data:`BAND`] (one scene per
family: the scenes are independent draws for the binomial intervals of :mod:`ked_research.atlas.calibration`).
Every scene is the atlas's campaign scene (:func:`ked_research.atlas.compute.spec_of`: the Exudyn settings are
the registered defaults, ``DynamicSettings()``: 4 elements, 720 steps, from the ramp) run by the ``quasi_static``,
``linear`` and ``dynamic`` solvers (:func:`ked_research.atlas.confirm.confirm_scene`); the records are
:class:`~ked_research.atlas.confirm.ConfirmRecord` rows of the atlas table ``/threshold`` (kept apart from
``/confirm``, whose per-family ratio walks give the linear model's limits).  A failed solver is stored
with its reason; rerunning resumes (stored keys are skipped).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ked_research.atlas import store as atlas_store
from ked_research.atlas.confirm import ConfirmPoint, confirm_points
from ked_research.atlas.kinds import FOUR_BAR, AtlasKind, kind_of

BAND = 0.25
"""Half width of the threshold band: scenes at r within +-25 % of their family's r10."""
MECHANISMS = FOUR_BAR.mechanisms
TABLE = "threshold"
DEFAULT_THRESHOLD = 400
"""Scenes of the default threshold sample's first draw (50 per stratum)."""
DEFAULT_TOP_UP = 400
"""Scenes of its second, independent draw (50 per stratum): a stratum's margins need at least
``ked_research.atlas.calibration.MIN_STRATUM`` Exudyn answers."""


def select_threshold(families: dict[str, np.ndarray], n: int, seed: int = 0,
                     band: float = BAND, draw: int = 0, kind: AtlasKind = FOUR_BAR) -> list[ConfirmPoint]:
    """The stratified threshold sample of ``n`` scenes over the strata of ``kind`` (see the module
    docstring); ``draw`` > 0 an independent further draw of the same design (its own random stream), which
    tops up every stratum."""
    rng = np.random.default_rng([seed, 2] if draw == 0 else [seed, 2, draw])
    r10 = np.asarray(families.get("r10", []), float)
    points: list[ConfirmPoint] = []
    for i, mm, mech in _picks(families, n, kind, rng):
        f = float(rng.uniform(1.0 - band, 1.0 + band))
        r = round(f * float(r10[i]), 6)
        points.append(ConfirmPoint(int(families["linkage"][i]), mech, mm, round(r / float(r10[i]), 4), r,
                                   float(r10[i])))
    return points


def _picks(families: dict[str, np.ndarray], n: int, kind: AtlasKind, rng: np.random.Generator):
    """(family row, mass model, mechanism) of about ``n`` families split evenly over the strata of ``kind``:
    per stratum, its crossed families in equal chunks of their r10, one drawn from each (lazily: the caller
    draws its own numbers from ``rng`` between two picks)."""
    r10 = np.asarray(families.get("r10", []), float)
    status = np.asarray(families.get("r10_status", []), dtype=object)
    strata = [(mm, mech) for mm in kind.mass_models for mech in kind.mechanisms]
    quota = [n // len(strata) + (j < n % len(strata)) for j in range(len(strata))]
    for (mm, mech), q in zip(strata, quota):
        rows = [i for i in range(r10.size) if status[i] == "crossed" and np.isfinite(r10[i])
                and families["mass_model"][i] == mm and families["mechanism"][i] == mech]
        if not rows or not q:
            continue
        order = np.array(sorted(rows, key=lambda i: r10[i]))
        for chunk in np.array_split(order, min(q, order.size)):
            yield int(rng.choice(chunk)), mm, mech


TARGET = (0.7, 1.05)
"""Predicted errors (multiples of the tolerance) the targeted draw aims at: where unsafe calls live."""


def speed_at_error(ratios: np.ndarray, errors: np.ndarray, target: float) -> float:
    """The speed ratio where a family's swept error first reaches ``target`` [1], interpolated between the two
    grid ratios around the crossing as a power law e ~ r^p (the inertia loads' r^2 near rest); nan if the
    sweep never reaches it from below."""
    e = np.asarray(errors, float)
    for i in range(1, e.size):
        if not np.isfinite(e[i]):
            return math.nan
        if e[i] >= target:
            lo, hi = e[i - 1], e[i]
            if not (np.isfinite(lo) and 0.0 < lo < target):
                return math.nan
            p = math.log(hi / lo) / math.log(ratios[i] / ratios[i - 1])
            return float(ratios[i - 1] * (target / lo) ** (1.0 / p))
    return math.nan


def select_targeted(families: dict[str, np.ndarray], ratios: Sequence[float], n: int, seed: int = 0,
                    tolerance: float = 0.10, kind: AtlasKind = FOUR_BAR) -> list[ConfirmPoint]:
    """A third, independent draw aimed at the predicted error: per stratum of ``kind`` (``n`` split evenly),
    families drawn from equal chunks of their r10 as in :func:`select_threshold`, each at the speed ratio where
    its swept quasi-static vs linear error reaches u x ``tolerance``, u uniform on :data:`TARGET`
    (:func:`speed_at_error`), so that the scenes concentrate where a call can be unsafe."""
    rng = np.random.default_rng([seed, 2, 99])
    r10 = np.asarray(families.get("r10", []), float)
    hist = np.asarray(families.get("history_error", np.zeros((0, len(ratios)))), float)
    points: list[ConfirmPoint] = []
    for i, mm, mech in _picks(families, n, kind, rng):
        r = speed_at_error(np.asarray(ratios, float), hist[i], float(rng.uniform(*TARGET)) * tolerance)
        if np.isfinite(r):
            r = round(r, 6)
            points.append(ConfirmPoint(int(families["linkage"][i]), mech, mm, round(r / float(r10[i]), 4), r,
                                       float(r10[i])))
    return points


def run_threshold(path: Path, *, n: int = DEFAULT_THRESHOLD, top_up: int = DEFAULT_TOP_UP, targeted: int = 0,
                  seed: int = 0, workers: int = 2, scheduler: str | None = None, progress: bool = False,
                  echo: Callable[[str], Any] = print) -> dict[str, int]:
    """Confirm the threshold sample's scenes (``n`` of the first draw, ``top_up`` of the second, ``targeted`` of
    the draw aimed at the predicted error, :func:`select_targeted`) not yet stored in the atlas file
    (resumable)."""
    atlas_store.check_atlas(path, {"seed": seed})
    families, kind = atlas_store.read(path, "families"), kind_of(path)
    points = select_threshold(families, n, seed, kind=kind) + (
        select_threshold(families, top_up, seed, draw=1, kind=kind) if top_up else [])
    if targeted:
        points += select_targeted(families, atlas_store.attrs(path)["ratios"], targeted, seed, kind=kind)
    return confirm_points(path, list({p.key: p for p in points}.values()), TABLE, seed, workers=workers,
                          scheduler=scheduler, progress=progress, echo=echo)
