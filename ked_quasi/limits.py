"""Where a linear small-deflection answer holds, and how it says when it does not.

The quasi-static and linear KED models are linear in the deflection: they assume the linkage moves
along its rigid path and deforms little.  An answer whose coupler-point deflection is a sizeable
fraction of the linkage, or whose section rotation is large, is outside that theory: the harness
flags it (a warning, a flag in JSON and HDF5) instead of printing it as a result.

* ``large_deflection``: peak |d| (dx, dy of P) > :data:`MAX_DEFLECTION_FRACTION` x the shortest link
* ``large_rotation``: peak |rotation| of the section at P > :data:`MAX_ROTATION_RAD`
* ``non_finite``: the answer has NaN or infinite values (a singular frozen structure)

The bounds are where the geometric nonlinearity of a beam reaches a few percent: a tip deflection of
10 % of the length changes the tip position along the beam by about 0.6 % of the deflection and the
load's lever arm by about 10 %; a rotation of 0.1 rad changes sin(phi) from phi by 0.2 %.
"""

from __future__ import annotations

import numpy as np

MAX_DEFLECTION_FRACTION = 0.1
"""Largest peak deflection of P, as a fraction of the shortest link, that the linear theory covers."""
MAX_ROTATION_RAD = 0.1
"""Largest peak rotation [rad] of the section at P that the linear theory covers."""
FLAGS = ("large_deflection", "large_rotation", "non_finite")


def shortest_link(linkage: object) -> float:
    """The shortest link [m] of a four-bar (ground included) or of a linkage that states its own
    (``shortest_link``, e.g. a slider-crank)."""
    own = getattr(linkage, "shortest_link", None)
    if own is not None:
        return float(own)
    fb = linkage
    return min(fb.crank, fb.coupler, fb.follower, fb.extender, fb.ground)  # type: ignore[attr-defined]


def flags(deflection: np.ndarray, fourbar: object) -> tuple[str, ...]:
    """The validity flags of a (n, 3) deflection history (dx, dy [m], rotation [rad]) of ``fourbar``."""
    d = np.asarray(deflection, dtype=float)
    out = []
    if not np.all(np.isfinite(d)):
        out.append("non_finite")
    with np.errstate(invalid="ignore"):
        shortest = shortest_link(fourbar)
        if np.nanmax(np.hypot(d[:, 0], d[:, 1]), initial=0.0) > MAX_DEFLECTION_FRACTION * shortest:
            out.append("large_deflection")
        if np.nanmax(np.abs(d[:, 2]), initial=0.0) > MAX_ROTATION_RAD:
            out.append("large_rotation")
    return tuple(out)


def describe(found: tuple[str, ...], deflection: np.ndarray, fourbar: object) -> str:
    """One line saying which bounds the answer leaves (empty if none)."""
    if not found:
        return ""
    d = np.asarray(deflection, dtype=float)
    shortest = shortest_link(fourbar)
    parts = []
    if "large_deflection" in found:
        peak = float(np.nanmax(np.hypot(d[:, 0], d[:, 1])))
        parts.append(f"peak deflection {1e3 * peak:.4g} mm > {MAX_DEFLECTION_FRACTION:.0%} of the shortest link "
                     f"({1e3 * shortest:.4g} mm)")
    if "large_rotation" in found:
        parts.append(f"peak rotation {float(np.nanmax(np.abs(d[:, 2]))):.3g} rad > {MAX_ROTATION_RAD:g} rad")
    if "non_finite" in found:
        parts.append("non-finite values (singular frozen structure)")
    return ("outside the small-deflection range of the linear theory: " + "; ".join(parts)
            + "; the numbers are not a valid answer")
