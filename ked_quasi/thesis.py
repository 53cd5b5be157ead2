"""Reproducing the thesis's Tables I-III: an explicit "as printed" emulation of its FORTRAN listings.

Ali (1977) computes the coupler-point deflections of the source four-bar and of its right Roberts
cognate with the flexibility method, delta = beta^T F beta P, in three FORTRAN programs (Appendix B:
Case I, 2 lb at the coupler point; Appendix C: Case II, link masses at the joints; Appendix D:
Case III, the extender's mass in five nodes).  :func:`as_printed` computes Tables I-III by
following those listings formula by formula, in the listings' inch-pound-second units and frames.
Every departure of the listings from correct mechanics is a named switch of :class:`ThesisQuirks`:
with all switches on (the default) the emulation reproduces the published numbers; switching them
off one at a time walks to the corrected numbers; with ``ThesisQuirks.none()`` the emulation is the
correct flexibility analysis and equals :func:`ked_quasi.solver.solve_quasi_static` for the same
mass model (:func:`corrected_mass_model`) to round-off.  Nothing here is fitted or hard-coded: the
published numbers live in :mod:`ked_quasi.thesis_tables` and are only compared against.

Units: the four-bar comes in SI (:func:`ked_quasi.linkage.thesis_fourbar`) and is converted at the
edge to the listings' units (in, lbf, s; mass in lbf s^2/in, so force = mass * acceleration in
lbf); every table column is in inches, crank angles in degrees.

Listing conventions kept here (see ``results/thesis_errata.md`` for the errata and their effects):
source frame M = (0, 0), Q = (L5, 0), open branch; T2 crank, T3 coupler A->B, T4 follower Q->B
angles; the cognate listing's local frame has its crank pivot O at the origin and Q at (CL5, 0), its
CT3, CT4 are the directions E->D and E->Q; the global frame is the local one rotated by -BETA about
Q (BETA: the angle at B of the coupler triangle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from . import units
from .cognates import mechanism
from .kinematics import coupler_point
from .linkage import THESIS_RPM, THESIS_TIP_MASS_KG, FourBar, thesis_fourbar
from .massmodel import MassModel
from .scene import Scene
from .solver import solve_quasi_static
from .thesis_tables import TABLE_KEYS, TABLES, published

#: the listings' PI (22/7 to 9 decimals), used for the crank grid, alpha = PI/3, omega and the cognate angles
PI_LISTING = 3.142857143
#: Appendix B source program (the one that printed Table I's source columns): ALP [rad] and N [rpm]
APPENDIX_B_ALP = 1.762782545
APPENDIX_B_RPM = 400.0
#: g in the listings' mass -> force conversion W/(12 g) [ft/s^2], and the standard value
GC_LISTING_FT_S2 = 32.178
GC_STANDARD_FT_S2 = units.G0 / 0.3048
#: the listings' section and material constants (all links): CA [in^2], MI [in^4], ME [psi], DNTY [lb/in^3]
LISTING_AREA_IN2 = 0.1963495408
LISTING_SECOND_MOMENT_IN4 = 0.0030679615
LISTING_E_PSI = 10000000.0
LISTING_DENSITY_LB_IN3 = 0.098
#: rows of the published tables [deg]
TABLE_ANGLES_DEG = np.arange(0.0, 360.0, 20.0)
#: Case III: nodes on the extender (at L2, L2-2, ..., L2-8 in from A for L2 = 10 in)
CASE3_NODES = 5


@dataclass(frozen=True)
class ThesisQuirks:
    """The listings' departures from correct mechanics, each a switch (True = as printed).

    The fields are in the order of the quirk walk (``results/thesis_errata.md``): presentation and
    data first, then the mass models, the loads, the kinematics and statics, the constants.

    table1_appendix_b_params: Table I's source columns come from the Appendix B source program as
        printed, ALP = 1.762782545 rad (101 deg) and N = 400 rpm, not alpha = 60 deg at 300 rpm (its
        cognate program and the rigid X, Y columns use 60 deg, 300 rpm).
    cognate_local_frame: the cognate deflections (Tables I-III) are printed in the cognate listing's
        local frame (ground O->Q along +x), i.e. rotated by BETA = 19.1 deg from the global frame;
        the listing rotates the cognate's position back (lines 235-242) but not its deflections.
    case3_cognate_is_open_source_program: Table III's "cognate" is the Appendix D source program run
        with the cognate's link lengths and ALP = gamma = PI - (BETA + ALP) on the open branch, which
        is not the (crossed) cognate; off: the cognate listing's statics with the Case III masses.
    case3_block_diagonal_beta: Case III beta* is block diagonal, each node's load acting on its own
        copy of the four-bar with an extender cut at that node, so only the node at P loads P; off: all
        five node loads act on the one structure (crank, coupler, follower shared; extender a chain).
    case3_cumulative_masses: Case III node k carries rho*A*L2k (L2k = 10, 8, 6, 4, 2 in: the mass of
        the extender between A and the node) instead of rho*A*L2/5 each (total 3x the extender).
    case2_p_vector_slips: Case II system forces at the joints (source lines 65-72): P5 projects the
        crank-tip acceleration as YAA sin T2 - XAA cos T2 (not -XAA sin T2 + YAA cos T2); P6 uses
        YBA sin T4 - XBA cos T4 with XBA's ALPH3 term of the wrong sign; P7 takes the coupler mass with
        the acceleration of A instead of B; the B inertia is projected orthogonally on the follower and
        coupler (its other components dropped) instead of being decomposed on the two directions
        (the oblique split the force transformation's columns 6 and 7 require).  The cognate's P
        lines (scan lines 241-281 are missing) are reconstructed as the same formulas in the cognate
        listing's conventions: P4, P6, P7 with the cognate's reversed element directions, P5 with the
        source's projection slip, the cognate joint E's acceleration without slip.
    case2_beta_col7_sign: source Case II beta column 7 (a force at B along the coupler): the crank
        rows (-cos(T2-T3), sin(T2-T3)) are for a force pointing from B to A but the coupler row is +1
        (tension); consistent is -1.  (The cognate's column 7 is consistent.)
    load_sign_plus: the inertia loads are +m*a instead of the d'Alembert -m*a (every listing).
    om3_constant: source listings: OM3 = L1*OM2*sin(T4-T3)/(L3*sin(T3-T4)) = -L1*OM2/L3, a constant;
        correct is sin(T4-T2) in the numerator.  Wrong OM3 also makes ALPH3 and the accelerations wrong.
    g1_cos: source listings: G1 = -L2*cos(ALP+T3)*cos(T2) + ..., eq. (12) has sin(T2).
    i1_uses_l2: Case I and II source listings: I1 = sin(T4)*(L2*cos(T3) - ...), eq. (12) has L3*cos(T3).
    cognate_i1_moment_arm: Case I and II cognate listings: CI1 (the moment about P of the follower
        force, eq. (22)) is CL2*cos(T2)*sin(g) + CL3*cos(CT3-CT4) + CL2*sin(CT4)*cos(g), g = CALP-CT3;
        consistent with the listing's CG1, CH1 is -CL2*sin(CT4+g) + CL3*sin(CT4-CT3).
    crank_flex_uses_area: Case I and II listings (source and cognate): crank bending flexibility
        L1^3/(3*CA*ME) instead of L1^3/(3*ME*MI).
    pi_22_7: PI = 3.142857143 for the crank grid T2 = P2*2*PI/360, alpha = PI/3, omega = 2*PI*N/60 and
        the cognate's angles.
    gc_32_178: mass -> force conversion W/(12*32.178) instead of W/(12*32.174).
    listing_constants: section and material constants typed into the listings (CA = 0.1963495408 in^2,
        MI = 0.0030679615 in^4, ME = 1e7 psi, DNTY = 0.098 lb/in^3) instead of the four-bar's sections.
    """

    table1_appendix_b_params: bool = True
    cognate_local_frame: bool = True
    case3_cognate_is_open_source_program: bool = True
    case3_block_diagonal_beta: bool = True
    case3_cumulative_masses: bool = True
    case2_p_vector_slips: bool = True
    case2_beta_col7_sign: bool = True
    load_sign_plus: bool = True
    om3_constant: bool = True
    g1_cos: bool = True
    i1_uses_l2: bool = True
    cognate_i1_moment_arm: bool = True
    crank_flex_uses_area: bool = True
    pi_22_7: bool = True
    gc_32_178: bool = True
    listing_constants: bool = True

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """Quirk names in walk order."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def none(cls) -> ThesisQuirks:
        """All quirks off: the corrected analysis."""
        return cls(**{n: False for n in cls.names()})

    def without(self, *names: str) -> ThesisQuirks:
        """Copy with the named quirks switched off."""
        return self.with_(**{n: False for n in names})

    def with_(self, **switches: bool) -> ThesisQuirks:
        """Copy with some switches set; unknown names raise ValueError."""
        unknown = set(switches) - set(self.names())
        if unknown:
            raise ValueError(f"unknown quirk(s) {', '.join(sorted(unknown))}; known: {', '.join(self.names())}")
        return replace(self, **{k: bool(v) for k, v in switches.items()})

    def active(self) -> tuple[str, ...]:
        return tuple(n for n in self.names() if getattr(self, n))


#: the quirks that can change each table (Table I's cognate, II and III have no Appendix B parameters, ...)
QUIRKS_BY_TABLE = {
    "I": ("table1_appendix_b_params", "cognate_local_frame", "load_sign_plus", "om3_constant", "g1_cos",
          "i1_uses_l2", "cognate_i1_moment_arm", "crank_flex_uses_area", "pi_22_7", "gc_32_178",
          "listing_constants"),
    "II": ("cognate_local_frame", "case2_p_vector_slips", "case2_beta_col7_sign", "load_sign_plus",
           "om3_constant", "g1_cos", "i1_uses_l2", "cognate_i1_moment_arm", "crank_flex_uses_area", "pi_22_7",
           "gc_32_178", "listing_constants"),
    "III": ("cognate_local_frame", "case3_cognate_is_open_source_program", "case3_block_diagonal_beta",
            "case3_cumulative_masses", "load_sign_plus", "om3_constant", "g1_cos", "cognate_i1_moment_arm",
            "pi_22_7", "gc_32_178", "listing_constants"),
}


@dataclass(frozen=True)
class ThesisTable:
    """One table's comparison columns over the crank angles (angles in deg, the rest in inches)."""

    name: str
    crank_angle_deg: np.ndarray
    x_in: np.ndarray
    y_in: np.ndarray
    source_dx_in: np.ndarray
    source_dy_in: np.ndarray
    cognate_dx_in: np.ndarray
    cognate_dy_in: np.ndarray

    def column(self, key: str) -> np.ndarray:
        if key not in TABLE_KEYS:
            raise ValueError(f"column must be one of {', '.join(TABLE_KEYS)}; got {key!r}")
        return getattr(self, key)

    def as_dict(self) -> dict[str, list[float]]:
        """JSON-ready: the arrays of :data:`ked_quasi.thesis_tables.TABLE_KEYS` as lists."""
        return {k: [float(v) for v in getattr(self, k)] for k in TABLE_KEYS}


# ---------------------------------------------------------------------------------------------------
# data at the edge: SI four-bar -> the listings' inch-pound-second quantities


@dataclass(frozen=True)
class _Data:
    """Listing inputs: lengths [in], ALP [rad], PI, material per link (crank, coupler, extender, follower)."""

    L1: float
    L2: float
    L3: float
    L4: float
    L5: float
    alp: float
    pi: float
    E: np.ndarray  # psi
    A: np.ndarray  # in^2
    I: np.ndarray  # in^4
    rho: np.ndarray  # lbm/in^3
    gc: float  # in/s^2: lbm -> lbf s^2/in


def _check_frame(fb: FourBar) -> None:
    if fb.crank_pivot != (0.0, 0.0) or fb.follower_pivot[1] != 0.0 or fb.follower_pivot[0] <= 0.0:
        raise ValueError("fourbar: the listings' frame needs crank_pivot (0, 0) and follower_pivot on +x")
    if fb.branch != "open" or fb.direction != "ccw":
        raise ValueError("fourbar: the listings analyse the open branch driven counter-clockwise")
    if not 0.0 < fb.coupler_angle < math.pi:
        raise ValueError("fourbar: the listings' cognate construction needs 0 < coupler_angle < pi")


def _data(fb: FourBar, q: ThesisQuirks) -> _Data:
    _check_frame(fb)
    i = units.INCH
    pi = PI_LISTING if q.pi_22_7 else math.pi
    if q.listing_constants:
        E = np.full(4, LISTING_E_PSI)
        A = np.full(4, LISTING_AREA_IN2)
        I = np.full(4, LISTING_SECOND_MOMENT_IN4)
        rho = np.full(4, LISTING_DENSITY_LB_IN3)
    else:
        E = np.array([s.youngs_modulus / units.PSI for s in fb.sections])
        A = np.array([s.area / i**2 for s in fb.sections])
        I = np.array([s.second_moment / i**4 for s in fb.sections])
        rho = np.array([s.density * i**3 / units.POUND_MASS for s in fb.sections])
    gc = 12.0 * (GC_LISTING_FT_S2 if q.gc_32_178 else GC_STANDARD_FT_S2)
    return _Data(fb.crank / i, fb.extender / i, fb.coupler / i, fb.follower / i, fb.ground / i,
                 fb.coupler_angle * pi / math.pi, pi, E, A, I, rho, gc)


def _flexibility(d: _Data, L1: float, a: np.ndarray, L3: float, L4: float, crank_area: bool) -> np.ndarray:
    """Element flexibility F (K, 8, 8) of eq. (29) for extenders of lengths ``a`` (K,) [in/lbf, 1/lbf...].

    Element order f1..f8: extender axial, transverse, moment; crank axial, transverse; follower
    axial; coupler axial, end moment.  Link order of the material arrays: crank, coupler, extender,
    follower.
    """
    E, A, I = d.E, d.A, d.I
    F = np.zeros((a.size, 8, 8))
    F[:, 0, 0] = a / (A[2] * E[2])
    F[:, 1, 1] = a**3 / (3.0 * E[2] * I[2])
    F[:, 1, 2] = F[:, 2, 1] = a**2 / (2.0 * E[2] * I[2])
    F[:, 2, 2] = a / (E[2] * I[2])
    F[:, 3, 3] = L1 / (A[0] * E[0])
    F[:, 4, 4] = L1**3 / (3.0 * E[0] * (A[0] if crank_area else I[0]))
    F[:, 5, 5] = L4 / (A[3] * E[3])
    F[:, 6, 6] = L3 / (A[1] * E[1])
    F[:, 7, 7] = L3 / (3.0 * E[1] * I[1])
    return F


def _stack_beta(rows: list[list[np.ndarray]]) -> np.ndarray:
    """(8 rows of 3 entries, each (n, K)) -> beta (n, K, 8, 3)."""
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


@dataclass(frozen=True)
class _Frame:
    """One listing's mechanism at n crank angles, with K points on its extender (listing frame).

    acc (n, K, 2) accelerations of the extender points [in/s^2]; beta (n, K, 8, 3) the force
    transformation of the four-bar whose extender ends at each point; F (K, 8, 8); P (n, 2) the rigid
    coupler point; rotation: angle [rad] from the listing frame to the global frame; case II data:
    acc_A, acc_B (n, 2) true, acc_B_listing (n, 2) as printed (source), crank axes e2, n2 as the
    element forces f4, f5 act, e_follower (f6 direction), u_col7 (direction of the B force whose
    crank rows column 7 carries), col7 (n, 8) that column, link_lengths (crank, coupler, extender,
    follower) [in], angles T3, T4 (listing convention).
    """

    P: np.ndarray
    acc: np.ndarray
    beta: np.ndarray
    F: np.ndarray
    rotation: float
    acc_A: np.ndarray
    acc_B: np.ndarray
    acc_B_listing: np.ndarray
    e2: np.ndarray
    n2: np.ndarray
    e_follower: np.ndarray
    u_col7: np.ndarray
    col7: np.ndarray
    link_lengths: tuple[float, float, float, float]
    T3: np.ndarray
    T4: np.ndarray


def _xy(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.stack([x, y], axis=-1)


def _source_frame(d: _Data, T2: np.ndarray, omega: float, q: ThesisQuirks, fracs: np.ndarray, *,
                  alp: float, lengths: tuple[float, float, float, float, float] | None = None,
                  i1_l2: bool, crank_area: bool) -> _Frame:
    """The source listings (Appendices B, C, D), lines 8-60 of Appendix B and their Case III copies.

    ``fracs`` (K,): extender points at fractions of L2 from A (Case III: 1, 0.8, ..., 0.2).
    """
    L1, L2, L3, L4, L5 = lengths if lengths is not None else (d.L1, d.L2, d.L3, d.L4, d.L5)
    a = L2 * fracs  # (K,)
    K1, K2, K4 = L5 / L1, L5 / L4, L5 / L3
    K3 = (L1 * L1 - L3 * L3 + L4 * L4 + L5 * L5) / (2.0 * L1 * L4)
    K5 = (L4 * L4 - L5 * L5 - L1 * L1 - L3 * L3) / (2.0 * L1 * L3)
    c, s = np.cos(T2), np.sin(T2)
    AA, BB, CC = c + K3 - K1 - K2 * c, -2.0 * s, K1 + K3 - (1.0 + K2) * c
    DD, EE, FF = K4 * c + c + K5 - K1, -2.0 * s, K4 * c - c + K5 + K1
    T3 = 2.0 * np.arctan((-EE - np.sqrt(EE * EE - 4.0 * DD * FF)) / (2.0 * DD))
    T4 = 2.0 * np.arctan((-BB - np.sqrt(BB * BB - 4.0 * AA * CC)) / (2.0 * AA))
    CTX = np.cos(T4 - T3) / np.sin(T4 - T3)
    om2 = omega
    num = np.sin(T4 - T3) if q.om3_constant else np.sin(T4 - T2)
    OM3 = L1 * om2 * num / (L3 * np.sin(T3 - T4))
    OM4 = L1 * om2 * np.sin(T2 - T3) / (L4 * np.sin(T4 - T3))
    AJ, BJ, DJ, EJ = L4 * np.sin(T4), L3 * np.sin(T3), L4 * np.cos(T4), L3 * np.cos(T3)
    CJ = L1 * om2**2 * c + L3 * OM3**2 * np.cos(T3) - L4 * OM4**2 * np.cos(T4)
    FJ = L4 * OM4**2 * np.sin(T4) - L1 * om2**2 * s - L3 * OM3**2 * np.sin(T3)
    ALPH3 = (CJ * DJ - AJ * FJ) / (AJ * EJ - BJ * DJ)
    sa, ca = np.sin(alp + T3), np.cos(alp + T3)
    P = _xy(L1 * c + L2 * ca, L1 * s + L2 * sa)
    an = a[None, :]
    cn, sn, can, san = c[:, None], s[:, None], ca[:, None], sa[:, None]
    om3, al3 = OM3[:, None], ALPH3[:, None]
    acc = _xy(-L1 * om2**2 * cn - an * om3**2 * can - an * al3 * san,
              -L1 * om2**2 * sn + an * al3 * can - an * om3**2 * san)
    # eqs. (10)-(18): a..i of the 3x3 equilibrium of the coupler body, Cramer's rule
    A1, B1, C1, D1, E1, F1 = cn, -sn, np.cos(T4)[:, None], sn, cn, np.sin(T4)[:, None]
    G1 = -an * can * (cn if q.g1_cos else sn) + an * san * cn
    H1 = -an * can * cn - an * san * sn
    arm3 = L2 if i1_l2 else L3
    I1 = F1 * (arm3 * np.cos(T3)[:, None] - an * can) + C1 * (an * san - L3 * np.sin(T3)[:, None])
    R1 = A1 * (E1 * I1 - F1 * H1) - B1 * (D1 * I1 - F1 * G1) + C1 * (D1 * H1 - E1 * G1)
    ctx = CTX[:, None]
    z, o = 0.0 * R1, 1.0 + 0.0 * R1
    beta = _stack_beta([
        [can + z, san + z, z],
        [-san + z, can + z, z],
        [z, z, o],
        [(E1 * I1 - F1 * H1) / R1, (C1 * H1 - B1 * I1) / R1, (B1 * F1 - C1 * E1) / R1],
        [(F1 * G1 - D1 * I1) / R1, (A1 * I1 - C1 * G1) / R1, (C1 * D1 - A1 * F1) / R1],
        [(D1 * H1 - E1 * G1) / R1, (B1 * G1 - A1 * H1) / R1, (A1 * E1 - B1 * D1) / R1],
        [ctx * san * an / L3, -can * ctx * an / L3, -ctx / L3 + z],
        [-san * an, can * an, o],
    ])
    # Case II: joint accelerations (lines 48-51 of Appendix C), element axes, beta column 7
    acc_A = _xy(-L1 * c * om2**2, -L1 * s * om2**2)
    bx = -L1 * om2**2 * c - L3 * OM3**2 * np.cos(T3)
    by = -L1 * om2**2 * s - L3 * OM3**2 * np.sin(T3) + L3 * ALPH3 * np.cos(T3)
    acc_B = _xy(bx - L3 * ALPH3 * np.sin(T3), by)
    acc_B_listing = _xy(bx + L3 * ALPH3 * np.sin(T3), by)
    col7 = np.zeros((T2.size, 8))
    col7[:, 3] = -np.cos(T2 - T3)
    col7[:, 4] = np.sin(T2 - T3)
    col7[:, 6] = 1.0 if q.case2_beta_col7_sign else -1.0
    return _Frame(
        P=P, acc=acc, beta=beta, F=_flexibility(d, L1, a, L3, L4, crank_area), rotation=0.0,
        acc_A=acc_A, acc_B=acc_B, acc_B_listing=acc_B_listing,
        e2=_xy(c, s), n2=_xy(-s, c), e_follower=_xy(np.cos(T4), np.sin(T4)),
        u_col7=_xy(-np.cos(T3), -np.sin(T3)), col7=col7, link_lengths=(L1, L3, L2, L4), T3=T3, T4=T4,
    )


def _cognate_lengths(d: _Data) -> tuple[float, float, float, float, float, float, float]:
    """Cognate construction of the listings (Appendix B cognate, lines 32-42): CL1..CL5, BETA, CALP."""
    L1, L2, L3, L4, L5, alp = d.L1, d.L2, d.L3, d.L4, d.L5, d.alp
    k = L2 / L3
    CL4 = math.sqrt(L2 * L2 + L3 * L3 - 2.0 * L2 * L3 * math.cos(alp))
    CL3 = L4 * CL4 / L3
    CL2 = k * L4
    CL5 = math.sqrt((k * L5) ** 2 + L5 * L5 - 2.0 * L5 * L5 * k * math.cos(alp))
    CL1 = L1 * CL4 / L3
    CBTA = (L3 * L3 + CL4 * CL4 - L2 * L2) / (2.0 * L3 * CL4)
    BETA = math.atan(math.sqrt(1.0 - CBTA**2) / CBTA)
    CALP = d.pi - (BETA + alp)
    return CL1, CL2, CL3, CL4, CL5, BETA, CALP


def _cognate_frame(d: _Data, T2: np.ndarray, omega: float, q: ThesisQuirks, fracs: np.ndarray, *,
                   crank_area: bool) -> _Frame:
    """The cognate listings (Appendix B second program, Appendix C cognate), lines 32-110."""
    CL1, CL2, CL3, CL4, CL5, BETA, CALP = _cognate_lengths(d)
    a = CL2 * fracs
    CK1, CK2, CK4 = CL5 / CL1, -CL5 / CL4, -CL5 / CL3
    CK3 = (CL3**2 - CL1**2 - CL4**2 - CL5**2) / (2.0 * CL1 * CL4)
    CK5 = (CL1**2 + CL3**2 + CL5**2 - CL4**2) / (2.0 * CL1 * CL3)
    c, s = np.cos(T2), np.sin(T2)
    CAA, CBB, CCC = c + CK3 - CK1 - CK2 * c, -2.0 * s, CK1 + CK3 - (1.0 + CK2) * c
    CDD, CEE, CFF = CK4 * c + c + CK5 - CK1, -2.0 * s, CK4 * c - c + CK5 + CK1
    CT3 = 2.0 * np.arctan((-CEE - np.sqrt(CEE * CEE - 4.0 * CDD * CFF)) / (2.0 * CDD))
    CT4 = 2.0 * np.arctan((-CBB - np.sqrt(CBB * CBB - 4.0 * CAA * CCC)) / (2.0 * CAA))
    g = CALP - CT3  # CALP-CT3 of the listing
    P = _xy(CL1 * c + CL2 * np.cos(d.pi - g), CL1 * s + CL2 * np.sin(d.pi - g))
    om2 = omega
    COM3 = CL1 * om2 * np.sin(T2 - CT4) / (CL3 * np.sin(CT3 - CT4))
    COM4 = CL1 * om2 * np.sin(CT3 - T2) / (CL4 * np.sin(CT4 - CT3))
    CAJ, CBJ, CDJ, CEJ = CL4 * np.sin(CT4), CL3 * np.sin(CT3), CL4 * np.cos(CT4), CL3 * np.cos(CT3)
    CCJ = -CL1 * om2**2 * c + CL3 * COM3**2 * np.cos(CT3) - CL4 * COM4**2 * np.cos(CT4)
    CFJ = CL1 * om2**2 * s - CL3 * COM3**2 * np.sin(CT3) + CL4 * COM4**2 * np.sin(CT4)
    CALPH3 = (CCJ * CDJ - CAJ * CFJ) / (CAJ * CEJ - CBJ * CDJ)
    an = a[None, :]
    sg, cg = np.sin(g)[:, None], np.cos(g)[:, None]
    cn, sn = c[:, None], s[:, None]
    com3, cal3 = COM3[:, None], CALPH3[:, None]
    acc = _xy(-CL1 * om2**2 * cn + an * com3**2 * cg - an * cal3 * sg,
              -CL1 * om2**2 * sn - an * com3**2 * sg - an * cal3 * cg)
    c4, s4 = np.cos(CT4)[:, None], np.sin(CT4)[:, None]
    c3, s3 = np.cos(CT3)[:, None], np.sin(CT3)[:, None]
    CA1, CB1, CC1, CD1, CE1, CF1 = -cn, sn, c4, -sn, -cn, s4
    CG1 = an * cn * sg + an * sn * cg
    CH1 = an * cn * cg - an * sn * sg
    if q.cognate_i1_moment_arm:
        CI1 = an * cn * sg + CL3 * c3 * c4 + an * s4 * cg + CL3 * s4 * s3
    else:
        CI1 = -an * (s4 * cg + c4 * sg) + CL3 * (s4 * c3 - c4 * s3)
    CR1 = CA1 * (CE1 * CI1 - CF1 * CH1) - CB1 * (CD1 * CI1 - CF1 * CG1) + CC1 * (CD1 * CH1 - CE1 * CG1)
    cctx = (np.cos(CT3 - CT4) / np.sin(CT3 - CT4))[:, None]
    z, o = 0.0 * CR1, 1.0 + 0.0 * CR1
    beta = _stack_beta([
        [-cg + z, sg + z, z],
        [-sg + z, -cg + z, z],
        [z, z, o],
        [(CE1 * CI1 - CF1 * CH1) / CR1, (CC1 * CH1 - CB1 * CI1) / CR1, (CB1 * CF1 - CC1 * CE1) / CR1],
        [(CF1 * CG1 - CD1 * CI1) / CR1, (CA1 * CI1 - CC1 * CG1) / CR1, (CC1 * CD1 - CA1 * CF1) / CR1],
        [(CD1 * CH1 - CE1 * CG1) / CR1, (CB1 * CG1 - CA1 * CH1) / CR1, (CA1 * CE1 - CB1 * CD1) / CR1],
        [-an * sg * cctx / CL3, -an * cg * cctx / CL3, cctx / CL3 + z],
        [-sg * an, -cg * an, o],
    ])
    acc_A = _xy(-CL1 * c * om2**2, -CL1 * s * om2**2)
    acc_B = _xy(-CL1 * om2**2 * c + CL3 * COM3**2 * np.cos(CT3) + CL3 * CALPH3 * np.sin(CT3),
                -CL1 * om2**2 * s + CL3 * COM3**2 * np.sin(CT3) - CL3 * CALPH3 * np.cos(CT3))
    col7 = np.zeros((T2.size, 8))
    col7[:, 3] = np.cos(CT3 - T2)
    col7[:, 4] = np.sin(CT3 - T2)
    col7[:, 6] = 1.0
    return _Frame(
        P=P, acc=acc, beta=beta, F=_flexibility(d, CL1, a, CL3, CL4, crank_area), rotation=-BETA,
        acc_A=acc_A, acc_B=acc_B, acc_B_listing=acc_B,
        e2=_xy(-c, -s), n2=_xy(s, -c), e_follower=_xy(np.cos(CT4), np.sin(CT4)),
        u_col7=_xy(-np.cos(CT3), -np.sin(CT3)), col7=col7, link_lengths=(CL1, CL3, CL2, CL4), T3=CT3, T4=CT4,
    )


# ---------------------------------------------------------------------------------------------------
# the three cases


def _sign(q: ThesisQuirks) -> float:
    return 1.0 if q.load_sign_plus else -1.0


def _mass(d: _Data, link: int, length: float | np.ndarray) -> float | np.ndarray:
    """Mass [lbf s^2/in] of ``length`` in of link ``link`` (0 crank, 1 coupler, 2 extender, 3 follower)."""
    return d.rho[link] * d.A[link] * length / d.gc


def _delta_case1(d: _Data, fr: _Frame, q: ThesisQuirks) -> np.ndarray:
    """Case I: delta = beta^T F beta P, P = (m a_P, 0) with 2 lb at P."""
    m = THESIS_TIP_MASS_KG / units.POUND_MASS / d.gc
    Pv = _sign(q) * m * np.concatenate([fr.acc[:, 0], np.zeros((fr.acc.shape[0], 1))], axis=1)
    b = fr.beta[:, 0]
    return np.einsum("nia,ij,njb,nb->na", b, fr.F[0], b, Pv)


def _case2_loads(d: _Data, fr: _Frame, q: ThesisQuirks, cognate: bool) -> np.ndarray:
    """Case II system forces P1..P8 [lbf] (Appendix C, lines 61-72), as printed or corrected."""
    L1, L3, L2, L4 = fr.link_lengths
    m1, m3, m2, m4 = (_mass(d, i, L) for i, L in enumerate((L1, L3, L2, L4)))
    n = fr.acc.shape[0]
    P = np.zeros((n, 8))
    P[:, 0:2] = m2 * fr.acc[:, 0]
    aA = fr.acc_A
    if q.case2_p_vector_slips:
        # as printed: P4 = M1*(XAA cos T2 + YAA sin T2), P5 = M1*(YAA sin T2 - XAA cos T2),
        # P6 = M4*(YBA sin T4 - XBA cos T4), P7 = M3*(YAA sin T3 - XAA cos T3); the cognate's lines
        # reconstructed with its reversed directions (P4, P6, P7 negated, see ThesisQuirks)
        c2, s2 = fr.e2[:, 0], fr.e2[:, 1]
        sg = -1.0 if cognate else 1.0
        c2s, s2s = sg * c2, sg * s2  # cos T2, sin T2 of the listing
        aB = fr.acc_B_listing
        c4, s4 = np.cos(fr.T4), np.sin(fr.T4)
        c3, s3 = np.cos(fr.T3), np.sin(fr.T3)
        P[:, 3] = sg * m1 * (aA[:, 0] * c2s + aA[:, 1] * s2s)
        P[:, 4] = m1 * (aA[:, 1] * s2s - aA[:, 0] * c2s)
        P[:, 5] = sg * m4 * (aB[:, 1] * s4 - aB[:, 0] * c4)
        P[:, 6] = sg * m3 * (aA[:, 1] * s3 - aA[:, 0] * c3)
    else:
        # crank mass at A in the crank's element axes; coupler and follower masses at B, decomposed on
        # the follower direction (column 6) and the column-7 direction
        P[:, 3] = m1 * (aA * fr.e2).sum(-1)
        P[:, 4] = m1 * (aA * fr.n2).sum(-1)
        FB = (m3 + m4) * fr.acc_B
        u, w = fr.e_follower, fr.u_col7
        det = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
        P[:, 5] = (FB[:, 0] * w[:, 1] - FB[:, 1] * w[:, 0]) / det
        P[:, 6] = (u[:, 0] * FB[:, 1] - u[:, 1] * FB[:, 0]) / det
    return _sign(q) * P


def _delta_case2(d: _Data, fr: _Frame, q: ThesisQuirks, cognate: bool) -> np.ndarray:
    """Case II: delta = beta1^T F beta2 P, beta2 = [beta1 | unit columns 4-6 | column 7 | unit 8] (eq. 30)."""
    n = fr.acc.shape[0]
    b1 = fr.beta[:, 0]
    b2 = np.zeros((n, 8, 8))
    b2[:, :, :3] = b1
    for j in (3, 4, 5, 7):
        b2[:, j, j] = 1.0
    b2[:, :, 6] = fr.col7
    return np.einsum("nia,ij,njb,nb->na", b1, fr.F[0], b2, _case2_loads(d, fr, q, cognate))


def _delta_case3(d: _Data, fr: _Frame, q: ThesisQuirks, fracs: np.ndarray) -> np.ndarray:
    """Case III: node loads m_k a_k at the extender points; deflection of node 1 (= P)."""
    L2 = fr.link_lengths[2]
    a = L2 * fracs
    m = _mass(d, 2, a if q.case3_cumulative_masses else np.full(a.size, L2 / fracs.size))
    Pk = _sign(q) * m[None, :, None] * fr.acc  # (n, K, 2)
    Pk = np.concatenate([Pk, np.zeros(Pk.shape[:2] + (1,))], axis=-1)
    b1 = fr.beta[:, 0]  # virtual unit load at P
    if q.case3_block_diagonal_beta:
        return np.einsum("nia,ij,njb,nb->na", b1, fr.F[0], b1, Pk[:, 0])
    # shared crank, follower, coupler elements (rows 4-8): the same F in every block
    shared = np.einsum("nia,ij,nkjb,nkb->na", b1[:, 3:], fr.F[0, 3:, 3:], fr.beta[:, :, 3:], Pk)
    # extender: the unit load at P carried to the section at node k (moment + (L2 - a_k) * shear)
    bv = np.broadcast_to(b1[:, None, :3, :], fr.beta[:, :, :3, :].shape).copy()
    bv[:, :, 2, :] += (L2 - a)[None, :, None] * b1[:, None, 1, :]
    ext = np.einsum("nkia,kij,nkjb,nkb->na", bv, fr.F[:, :3, :3], fr.beta[:, :, :3, :], Pk)
    return shared + ext


def _rotate(v: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def _check_table(table: str) -> str:
    if table not in TABLES:
        raise ValueError(f"table must be one of {', '.join(TABLES)}; got {table!r}")
    return table


def as_printed(table: str, quirks: ThesisQuirks | None = None, fourbar: FourBar | None = None,
               rpm: float = THESIS_RPM, angles_deg: np.ndarray | None = None) -> ThesisTable:
    """Table ``table`` ("I", "II", "III") computed the way the thesis's listings compute it.

    quirks: which listing errors to keep (default: all, the published computation); fourbar: the
    source four-bar in SI (default :func:`thesis_fourbar`, in the listings' frame); rpm: crank speed
    [rev/min] (Table I's source uses 400 while ``table1_appendix_b_params`` is on); angles_deg: the
    nominal crank angles P2 [deg] (default 0, 20, ..., 340).  Returns x, y (rigid coupler point) and
    the source and cognate deflections of the coupler point [in].
    """
    _check_table(table)
    q = ThesisQuirks() if quirks is None else quirks
    fb = thesis_fourbar() if fourbar is None else fourbar
    deg = TABLE_ANGLES_DEG if angles_deg is None else np.atleast_1d(np.asarray(angles_deg, dtype=float))
    d = _data(fb, q)
    T2 = deg * 2.0 * d.pi / 360.0
    omega = 2.0 * d.pi * rpm / 60.0
    one = np.array([1.0])
    case12 = table in ("I", "II")
    crank_area = q.crank_flex_uses_area and case12
    i1_l2 = q.i1_uses_l2 and case12
    rigid = _source_frame(d, T2, omega, q, one, alp=d.alp, i1_l2=i1_l2, crank_area=crank_area)
    if table == "I":
        if q.table1_appendix_b_params:
            src = _source_frame(d, T2, 2.0 * d.pi * APPENDIX_B_RPM / 60.0, q, one, alp=APPENDIX_B_ALP,
                                i1_l2=i1_l2, crank_area=crank_area)
        else:
            src = rigid
        cog = _cognate_frame(d, T2, omega, q, one, crank_area=crank_area)
        ds, dc = _delta_case1(d, src, q), _delta_case1(d, cog, q)
    elif table == "II":
        cog = _cognate_frame(d, T2, omega, q, one, crank_area=crank_area)
        ds, dc = _delta_case2(d, rigid, q, False), _delta_case2(d, cog, q, True)
    else:
        fracs = 1.0 - np.arange(CASE3_NODES) / CASE3_NODES
        src = _source_frame(d, T2, omega, q, fracs, alp=d.alp, i1_l2=False, crank_area=False)
        ds = _delta_case3(d, src, q, fracs)
        if q.case3_cognate_is_open_source_program:
            CL1, CL2, CL3, CL4, CL5, BETA, CALP = _cognate_lengths(d)
            cog = _source_frame(d, T2, omega, q, fracs, alp=CALP, lengths=(CL1, CL2, CL3, CL4, CL5),
                                i1_l2=False, crank_area=False)
            cog = replace(cog, rotation=-BETA)
        else:
            cog = _cognate_frame(d, T2, omega, q, fracs, crank_area=False)
        dc = _delta_case3(d, cog, q, fracs)
    dc2 = dc[:, :2] if q.cognate_local_frame else _rotate(dc[:, :2], cog.rotation)
    return ThesisTable(table, deg, rigid.P[:, 0], rigid.P[:, 1], ds[:, 0], ds[:, 1], dc2[:, 0], dc2[:, 1])


# ---------------------------------------------------------------------------------------------------
# the corrected solver and the published numbers, in the same layout


def corrected_mass_model(table: str) -> MassModel:
    """The harness mass model that the thesis's Case ``table`` stands for (SI).

    I: ``tip`` with 2 lb at P; II: ``joints`` with each link's whole mass at its far end (crank at A,
    coupler and follower at B, extender at P: ``joint_split=0``), no payload; III: ``extender`` in 5
    lumps at the sub-element ends (``placement="end"``), no payload (the Case III listing has none).
    """
    _check_table(table)
    if table == "I":
        return MassModel("tip", payload=THESIS_TIP_MASS_KG)
    if table == "II":
        return MassModel("joints", joint_split=0.0)
    return MassModel("extender", lumps=CASE3_NODES, placement="end")


def corrected(table: str, fourbar: FourBar | None = None, rpm: float = THESIS_RPM,
              angles_deg: np.ndarray | None = None) -> ThesisTable:
    """Table ``table`` from the corrected solver :func:`ked_quasi.solver.solve_quasi_static`.

    The cognate is :func:`ked_quasi.cognates.mechanism` (the right Roberts cognate, crossed) at the
    same crank angle measured from its own ground line; deflections in the global frame [in].
    """
    _check_table(table)
    fb = thesis_fourbar() if fourbar is None else fourbar
    deg = TABLE_ANGLES_DEG if angles_deg is None else np.atleast_1d(np.asarray(angles_deg, dtype=float))
    theta = np.radians(deg)
    mm = corrected_mass_model(table)
    rs = solve_quasi_static(Scene(fb, mm, rpm), theta)
    rc = solve_quasi_static(Scene(mechanism(fb, "cognate"), mm, rpm), theta)
    P = coupler_point(fb, theta) / units.INCH
    ds, dc = rs.deflection / units.INCH, rc.deflection / units.INCH
    return ThesisTable(table, deg, P[:, 0], P[:, 1], ds[:, 0], ds[:, 1], dc[:, 0], dc[:, 1])


def published_table(table: str) -> ThesisTable:
    """The published table's comparison columns, rows 0-340 deg, as printed (typos included)."""
    t = published(_check_table(table))
    return ThesisTable(table, *(t.column(k) for k in TABLE_KEYS))


def comparison(table: str, quirks: ThesisQuirks | None = None) -> dict[str, ThesisTable]:
    """``{"published", "as_printed", "corrected"}`` for one table on the published rows."""
    return {"published": published_table(table), "as_printed": as_printed(table, quirks),
            "corrected": corrected(table)}


def quirk_walk(table: str, order: tuple[str, ...] | None = None) -> list[tuple[str, ThesisTable]]:
    """Switch the quirks off one at a time (cumulatively, in ``order``, default walk order) and
    return ``[("as printed", t0), (name1, t1), ...]``: the last one is the corrected analysis."""
    names = ThesisQuirks.names() if order is None else order
    q = ThesisQuirks()
    out = [("as printed", as_printed(table, q))]
    for name in names:
        q = q.without(name)
        out.append((name, as_printed(table, q)))
    return out


def _max_change(a: ThesisTable, b: ThesisTable, mech: str) -> float:
    return max(float(np.max(np.abs(a.column(f"{mech}_{k}") - b.column(f"{mech}_{k}")))) for k in ("dx_in", "dy_in"))


def quirk_effects() -> list[dict[str, object]]:
    """Measured effect of each quirk [in]: per table, the max change of the source and cognate dX, dY
    columns when the quirk alone is switched off in the as-printed computation (``off_from_printed``)
    and when it alone is switched on in the corrected one (``on_from_corrected``); None where the quirk
    cannot touch the table."""
    base = {t: as_printed(t) for t in TABLES}
    none = {t: as_printed(t, ThesisQuirks.none()) for t in TABLES}
    out: list[dict[str, object]] = []
    for name in ThesisQuirks.names():
        row: dict[str, object] = {"quirk": name}
        for t in TABLES:
            if name not in QUIRKS_BY_TABLE[t]:
                row[t] = None
                continue
            off = as_printed(t, ThesisQuirks().without(name))
            on = as_printed(t, ThesisQuirks.none().with_(**{name: True}))
            row[t] = {"off_from_printed": {m: _max_change(off, base[t], m) for m in ("source", "cognate")},
                      "on_from_corrected": {m: _max_change(on, none[t], m) for m in ("source", "cognate")}}
        out.append(row)
    return out
