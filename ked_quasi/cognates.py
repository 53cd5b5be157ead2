"""Roberts cognates (Cayley construction) of a four-bar, in the global frame.

With the coupler triangle written as P - A = k (B - A) (complex k = extender/coupler * e^{i alpha}),
the third fixed pivot is O = k Q + (1 - k) M and

* the **right cognate** O-D-E-Q (crank at O, follower pivot Q) has O->D = (1-k)(A-M): its crank turns
  with the source crank, so it is crank-driven at the same speed and, measured from its own ground
  line O->Q, at the *same* crank angle; coupler D->E = (1-k)(Q-B), follower Q->E = P-B, coupler
  point P = D + k(B-Q);
* the **left cognate** M-E'-D'-O (pivots M, O) has its links at M turning with the source coupler and
  at O with the source follower: it cannot be driven by the source crank; it is reported as a
  four-bar with its crank at M, and ``crank_drivable`` tells whether that crank turns fully.  (For the
  thesis linkage it is a Grashof double-rocker whose short coupler turns fully: carried along by the
  source it passes its toggles and changes assembly branch twice per cycle.)
"""

from __future__ import annotations

import cmath
from dataclasses import dataclass

import numpy as np

from .kinematics import loop
from .linkage import FourBar, Section

MECHANISMS = ("source", "cognate")


@dataclass(frozen=True)
class Cognate:
    """One Roberts cognate: its four-bar and whether its crank can turn a full revolution."""

    name: str
    fourbar: FourBar
    crank_drivable: bool
    reason: str = ""


def _branch_of(M: complex, A: complex, B: complex, Q: complex) -> str:
    return "open" if ((Q - A).conjugate() * (B - A)).imag > 0 else "crossed"


def _common_section(fourbar: FourBar, sections: tuple[Section, ...] | None) -> tuple[Section, ...]:
    if sections is not None:
        if len(sections) != 4:
            raise ValueError("sections must be four Section objects (crank, coupler, extender, follower)")
        return tuple(sections)
    if len(set(fourbar.sections)) != 1:
        raise ValueError(
            "sections: the source links have different sections; pass the cognate's four sections "
            "explicitly (a cognate's links are new links, their sections are a design choice)"
        )
    return fourbar.sections


def roberts_cognates(
    fourbar: FourBar,
    sections: tuple[Section, Section, Section, Section] | None = None,
) -> tuple[Cognate, Cognate]:
    """Right (pivots O, Q) and left (pivots M, O) Roberts cognates of ``fourbar``.

    Each cognate's links get ``sections`` (default: the source's common section).  The cognate's
    branch is read off the assembled geometry at crank angle 0.
    """
    secs = _common_section(fourbar, sections)
    lp = loop(fourbar, np.array([0.0]))
    M, Q, k = lp.M, lp.Q, lp.k
    A = M + lp.z1[0]
    B = A + lp.z3[0]
    P = A + k * lp.z3[0]
    O = k * Q + (1 - k) * M

    # right cognate O-D-E-Q
    D = O + (1 - k) * (A - M)
    E = P + (Q - B)
    right_kw = dict(
        crank=abs(D - O), coupler=abs(E - D), follower=abs(E - Q), extender=abs(P - D),
        coupler_angle=cmath.phase((P - D) / (E - D)), sections=secs,
        crank_pivot=(O.real, O.imag), follower_pivot=(Q.real, Q.imag),
        branch=_branch_of(O, D, E, Q), direction=fourbar.direction,
    )
    right = _make("right", right_kw)

    # left cognate M-E'-D'-O, crank at M
    E1 = M + (P - A)
    D1 = P + (1 - k) * (M - A)
    left_kw = dict(
        crank=abs(E1 - M), coupler=abs(D1 - E1), follower=abs(D1 - O), extender=abs(P - E1),
        coupler_angle=cmath.phase((P - E1) / (D1 - E1)), sections=secs,
        crank_pivot=(M.real, M.imag), follower_pivot=(O.real, O.imag),
        branch=_branch_of(M, E1, D1, O), direction=fourbar.direction,
    )
    left = _make("left", left_kw)
    return right, left


def _make(name: str, kw: dict) -> Cognate:
    fb = FourBar(**kw, full_turn=False)
    failing = fb.failing_angles()
    if failing.size == 0:
        return Cognate(name, FourBar(**kw), True)
    deg = np.degrees(failing)
    reason = (f"{fb.grashof_class}: its crank cannot turn fully (no assembly for {failing.size} of 3600 "
              f"crank angles in {deg.min():.1f}..{deg.max():.1f} deg)")
    return Cognate(name, fb, False, reason)


def mechanism(fourbar: FourBar, name: str) -> FourBar:
    """The four-bar to analyse: ``"source"`` itself or its crank-driven (right) ``"cognate"``."""
    if name == "source":
        return fourbar
    if name == "cognate":
        right, _ = roberts_cognates(fourbar)
        if not right.crank_drivable:
            raise ValueError(f"mechanism: the right cognate cannot be crank-driven: {right.reason}")
        return right.fourbar
    raise ValueError(f"mechanism must be one of {', '.join(MECHANISMS)}; got {name!r}")
