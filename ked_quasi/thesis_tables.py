"""The thesis's published Tables I-III (Ali 1977), transcribed as data, with the known typos.

Source: S. A. Ali, *Kineto-elastodynamic analysis of a four-bar and its cognate mechanism*, M.S.
thesis, Oklahoma State University, 1977, Chapter V: Table I "Mass at path point (Case I)" (thesis
page 50), Table II "Mass at each joint (Case II)" (page 51), Table III "Distributed mass model
(Case III)" (page 52).  The numbers were taken verbatim from the text rendering of the scan,
``/work/shared/thesis/ali-1977-ked-four-bar-cognate.txt``; every row below carries the line number
of that file it comes from (Table I: lines 800-818, Table II: 826-844, Table III: 852-870).

Columns as printed, all in inches except the angle: input-link rotation [deg]; coupler point in
rigid mode X, Y; source-linkage deflections dX, dY; source coupler point in K.E.D. mode X_new, Y_new;
cognate-linkage deflections dX, dY; cognate coupler point in K.E.D. mode X_new, Y_new.  The printed
X_new, Y_new columns are the rigid X, Y plus the deflections (the cognate's too: its deflections are
added to the *source's* rigid coordinates).  Entries are kept exactly as printed, typos included
(e.g. Table II 220 deg source Y_new "2.99"); :data:`TYPOS` lists the entries judged to be misprints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: thesis page of each table
TABLE_PAGES = {"I": 50, "II": 51, "III": 52}
#: line range of each table in the text rendering of the thesis
TABLE_LINES = {"I": (800, 818), "II": (826, 844), "III": (852, 870)}
TABLE_TITLES = {
    "I": "Mass at path point (Case I)",
    "II": "Mass at each joint (Case II)",
    "III": "Distributed mass model (Case III)",
}
#: column keys, in the printed order (after the source line number)
COLUMNS = (
    "crank_angle_deg", "x_in", "y_in",
    "source_dx_in", "source_dy_in", "source_x_new_in", "source_y_new_in",
    "cognate_dx_in", "cognate_dy_in", "cognate_x_new_in", "cognate_y_new_in",
)
#: the columns of the machine-readable comparison (``ked thesis --json``)
TABLE_KEYS = ("crank_angle_deg", "x_in", "y_in", "source_dx_in", "source_dy_in", "cognate_dx_in", "cognate_dy_in")

# (line in the text file, angle, X, Y, src dX, src dY, src X_new, src Y_new, cog dX, cog dY, cog X_new, cog Y_new)
_I_ROWS = (
    (800, 0, 5.648, 9.004, -0.238, -0.539, 5.410, 8.465, -0.037, -0.567, 5.611, 8.437),
    (801, 20, 6.637, 13.033, -2.255, -3.486, 4.382, 9.547, -0.265, -1.311, 6.372, 11.722),
    (802, 40, 6.234, 16.328, -3.589, -4.197, 2.645, 12.131, -0.360, -1.474, 5.874, 14.854),
    (803, 60, 4.470, 18.648, -3.791, -3.670, 0.679, 14.978, -0.277, -1.395, 4.193, 17.253),
    (804, 80, 1.710, 19.849, -3.215, -2.804, -2.045, 17.045, -0.122, -1.265, 1.588, 18.584),
    (805, 100, -1.571, 19.845, -2.255, -1.891, -3.826, 17.954, 0.038, -1.113, -1.533, 18.732),
    (806, 120, -4.904, 18.655, -1.179, -1.003, -6.083, 17.652, 0.166, -0.933, -4.738, 17.722),
    (807, 140, -7.871, 16.418, -0.171, -0.156, -8.042, 15.992, 0.235, -0.723, -7.636, 15.695),
    (808, 160, -10.145, 13.382, -0.655, -0.660, -10.800, 12.722, 0.231, -0.493, -9.914, 12.889),
    (809, 180, -11.507, 9.873, 1.244, 1.465, -10.263, 11.338, 0.151, -0.254, -11.356, 9.619),
    (810, 200, -11.846, 6.261, 1.579, 2.276, -10.267, 8.537, 0.007, -0.008, -11.839, 6.253),
    (811, 220, -11.163, 2.923, 1.664, 3.079, -9.519, 6.002, -0.188, 0.249, -11.351, 3.172),
    (812, 240, -9.561, 0.223, 1.526, 3.823, -8.035, 4.046, -0.405, 0.525, -9.966, 0.748),
    (813, 260, -7.242, -1.515, 1.230, 4.433, -6.012, 2.918, -0.597, 0.814, -7.839, -0.701),
    (814, 280, -4.478, -2.026, 0.893, 4.820, -3.585, 2.794, -0.701, 1.087, -5.179, -0.939),
    (815, 300, -1.574, -1.131, 0.669, 4.867, -9.905, 3.736, -0.643, 1.268, -2.217, 0.137),
    (816, 320, 1.209, 1.218, 0.671, 4.333, 1.880, 5.551, -0.385, 1.680, 0.824, 2.898),
    (817, 340, 3.695, 4.812, 0.671, 2.641, 4.366, 7.453, -0.066, 0.513, 3.629, 5.325),
    (818, 360, 5.648, 9.004, -0.238, -0.539, 5.410, 8.465, -0.037, -0.567, 5.611, 8.437),
)
_II_ROWS = (
    (826, 0, 5.648, 9.004, -0.126, -0.062, 5.522, 8.942, -0.003, -0.046, 5.645, 8.958),
    (827, 20, 6.637, 13.033, -0.251, -0.074, 6.386, 12.959, -0.021, -0.106, 6.616, 12.928),
    (828, 40, 6.234, 16.328, -0.265, -0.039, 5.969, 16.289, -0.029, -0.119, 6.205, 16.208),
    (829, 60, 4.470, 18.648, -0.196, -0.011, 4.274, 18.637, -0.022, -0.112, 4.448, 18.536),
    (830, 80, 1.710, 19.849, -0.101, -0.001, 1.609, 19.848, -0.010, -0.101, 1.700, 19.748),
    (831, 100, -1.571, 19.845, -0.009, 0.000, -1.562, 19.845, 0.003, -0.089, -1.569, 19.756),
    (832, 120, -4.904, 18.655, 0.066, 0.001, -4.898, 18.656, 0.013, -0.075, -4.891, 18.581),
    (833, 140, -7.871, 16.418, 0.121, 0.004, -7.750, 16.422, 0.019, -0.058, -7.852, 16.360),
    (834, 160, -10.145, 13.382, 0.156, 0.012, -9.989, 13.394, 0.019, -0.039, -10.127, 13.342),
    (835, 180, -11.507, 9.873, 0.175, 0.027, -11.332, 9.900, 0.012, -0.020, -11.495, 9.853),
    (836, 200, -11.846, 6.261, 0.182, 0.046, -11.664, 6.307, 0.000, 0.000, -11.846, 6.261),
    (837, 220, -11.163, 2.923, 0.179, 0.067, -10.984, 2.99, -0.016, 0.021, -11.179, 2.944),
    (838, 240, -9.561, 0.223, 0.169, 0.088, -9.392, 0.311, -0.033, 0.043, -9.594, 0.266),
    (839, 260, -7.242, -1.515, 0.152, 0.101, -7.090, -1.414, -0.048, 0.065, -7.290, -1.449),
    (840, 280, -4.478, -2.026, 0.129, 0.104, -4.349, -1.922, -0.056, 0.087, -4.535, -1.939),
    (841, 300, -1.574, -1.131, 0.102, 0.090, -1.472, -1.041, -0.051, 0.102, -1.626, -1.029),
    (842, 320, 1.209, 1.218, 0.067, 0.057, 1.276, 1.275, -0.031, 0.094, 1.179, 1.312),
    (843, 340, 3.695, 4.812, 0.001, 0.000, 3.696, 4.812, -0.005, 0.041, 3.690, 4.853),
    (844, 360, 5.648, 9.004, -0.126, -0.062, 5.522, 8.942, -3.003, -0.046, 5.645, 8.956),
)
_III_ROWS = (
    (852, 0, 5.648, 9.004, -0.141, -0.090, 5.507, 8.914, 0.001, 0.072, 5.649, 9.076),
    (853, 20, 6.634, 13.033, -0.255, -0.115, 6.382, 12.918, -0.004, -0.044, 6.630, 12.989),
    (854, 40, 6.234, 16.328, -0.259, -0.051, 5.975, 16.277, -0.019, -0.118, 6.215, 16.010),
    (855, 60, 4.470, 18.648, -0.199, -0.008, 4.271, 18.640, -0.043, -0.112, 4.427, 18.536),
    (856, 80, 1.710, 19.849, -0.113, 0.002, 1.597, 19.851, -0.057, -0.091, 1.653, 19.758),
    (857, 100, -1.571, 19.845, -0.025, -0.002, -1.596, 19.843, -0.053, -0.068, -1.624, 19.777),
    (858, 120, -4.904, 18.655, 0.053, -0.007, -4.851, 18.649, -0.038, -0.046, -4.942, 18.609),
    (859, 140, -7.871, 16.418, 0.113, -0.003, -7.757, 16.415, -0.019, -0.024, -7.890, 16.394),
    (860, 160, -10.145, 13.382, 0.154, 0.010, -9.991, 13.392, -0.001, -0.003, -10.146, 13.379),
    (861, 180, -11.507, 9.873, 0.176, 0.032, -11.331, 9.905, 0.012, 0.020, -11.495, 9.893),
    (862, 200, -11.846, 6.261, 0.181, 0.057, -11.665, 6.318, 0.018, 0.042, -11.828, 6.303),
    (863, 220, -11.163, 2.923, 0.176, 0.078, -10.987, 3.001, 0.017, 0.061, -11.146, 2.984),
    (864, 240, -9.561, 0.223, 0.166, 0.091, -9.395, 0.314, 0.012, 0.076, -9.549, 0.299),
    (865, 260, -7.242, -1.515, 0.157, 0.100, -7.085, -1.415, 0.005, 0.089, -7.237, -1.426),
    (866, 280, -4.478, -2.026, 0.145, 0.107, -4.334, -1.919, -0.004, 0.101, -4.482, -2.025),
    (867, 300, -1.574, -1.131, 0.125, 0.104, -1.450, -1.027, -0.014, 0.111, -1.588, -1.020),
    (868, 320, 1.209, 1.218, 0.091, 0.080, 1.301, 1.298, -0.019, 0.117, 1.190, 1.335),
    (869, 340, 3.695, 4.812, 0.014, 0.017, 3.710, 4.829, -0.012, 0.114, 3.683, 4.926),
    (870, 360, 5.648, 9.004, -0.141, -0.090, 5.507, 8.914, 0.001, 0.072, 5.649, 9.076),
)

_ROWS = {"I": _I_ROWS, "II": _II_ROWS, "III": _III_ROWS}
TABLES = ("I", "II", "III")


@dataclass(frozen=True)
class PublishedTable:
    """One published table: ``columns[key]`` arrays (rows 0..360 deg as printed) and ``line`` (n,) the
    line of the thesis text file each row was read from."""

    name: str
    title: str
    page: int
    line: np.ndarray
    columns: dict[str, np.ndarray]

    def column(self, key: str, max_deg: float = 340.0) -> np.ndarray:
        """One column, rows up to ``max_deg`` (default 340: the 360 row repeats 0)."""
        return self.columns[key][self.columns["crank_angle_deg"] <= max_deg]

    def value(self, key: str, angle_deg: float) -> float:
        """The printed entry of column ``key`` at ``angle_deg``."""
        i = int(np.flatnonzero(self.columns["crank_angle_deg"] == angle_deg)[0])
        return float(self.columns[key][i])

    def source_line(self, angle_deg: float) -> int:
        return int(self.line[int(np.flatnonzero(self.columns["crank_angle_deg"] == angle_deg)[0])])


def published(name: str) -> PublishedTable:
    """Published Table ``name`` ("I", "II" or "III") as printed."""
    if name not in _ROWS:
        raise ValueError(f"table must be one of {', '.join(TABLES)}; got {name!r}")
    arr = np.array(_ROWS[name], dtype=float)
    cols = {k: arr[:, i + 1] for i, k in enumerate(COLUMNS)}
    return PublishedTable(name, TABLE_TITLES[name], TABLE_PAGES[name], arr[:, 0].astype(int), cols)


@dataclass(frozen=True)
class Typo:
    """A published entry judged to be a misprint: table, row, column key, printed value, the value the
    listing computes (``expected``, rounded as printed), and why it is judged a typo."""

    table: str
    angle_deg: float
    column: str
    printed: float
    expected: float
    reason: str


#: Misprints in the published tables.  The dX/dY entries are judged against the as-printed emulation
#: (:mod:`ked_quasi.thesis`, all quirks on), which reproduces every other entry of Tables I-III to
#: within the 0.0005 in print rounding (0.001 in at most); the K.E.D.-mode X_new/Y_new entries against
#: the printed rigid coordinate plus the printed deflection.
TYPOS: tuple[Typo, ...] = (
    Typo("I", 160.0, "source_dx_in", -0.655, 0.655,
         "sign flip: the listing gives +0.6555; the smooth dX curve rises from -0.171 (140 deg) to +1.244 "
         "(180 deg); the magnitude agrees to 0.0005 in"),
    Typo("I", 160.0, "source_dy_in", -0.660, 0.660,
         "sign flip: the listing gives +0.6603; dY rises from -0.156 (140 deg) to +1.465 (180 deg); the "
         "magnitude agrees to 0.0003 in.  The printed X_new/Y_new (-10.800, 12.722) carry the wrong sign too"),
    Typo("I", 320.0, "cognate_dy_in", 1.680, 1.168,
         "digit transposition (1.168 -> 1.680): the listing gives 1.1680; the neighbours are 1.268 (300 deg) and "
         "0.513 (340 deg), so 1.680 would be an isolated spike; the printed Y_new 2.898 = 1.218 + 1.680 copies it"),
    Typo("III", 20.0, "x_in", 6.634, 6.637,
         "digit slip: the rigid X at 20 deg is 6.637 in Tables I and II and in the listing (6.6373); the rigid "
         "path does not depend on the mass model"),
    # K.E.D.-mode columns (printed rigid coordinate + printed deflection); not part of the comparison keys
    Typo("I", 80.0, "source_x_new_in", -2.045, -1.505, "addition slip: rigid X 1.710 + dX -3.215 = -1.505"),
    Typo("I", 140.0, "source_y_new_in", 15.992, 16.262, "addition slip: rigid Y 16.418 + dY -0.156 = 16.262"),
    Typo("I", 220.0, "source_x_new_in", -9.519, -9.499, "digit slip: rigid X -11.163 + dX 1.664 = -9.499"),
    Typo("I", 300.0, "source_x_new_in", -9.905, -0.905, "digit slip: rigid X -1.574 + dX 0.669 = -0.905"),
    Typo("II", 100.0, "source_x_new_in", -1.562, -1.580, "sign slip: rigid X -1.571 + dX -0.009 = -1.580"),
    Typo("II", 120.0, "source_x_new_in", -4.898, -4.838, "digit slip: rigid X -4.904 + dX 0.066 = -4.838"),
    Typo("III", 40.0, "cognate_y_new_in", 16.010, 16.210, "digit slip: rigid Y 16.328 + dY -0.118 = 16.210"),
    Typo("III", 280.0, "cognate_y_new_in", -2.025, -1.925, "digit slip: rigid Y -2.026 + dY 0.101 = -1.925"),
    Typo("II", 360.0, "cognate_dx_in", -3.003, -0.003,
         "digit slip: the 360 deg row repeats the 0 deg row, whose cognate dX is -0.003"),
    Typo("II", 360.0, "cognate_y_new_in", 8.956, 8.958,
         "digit slip: the 360 deg row repeats the 0 deg row (Y_new 8.958 = 9.004 - 0.046)"),
)


def typos(table: str | None = None, column: str | None = None) -> tuple[Typo, ...]:
    """The listed typos, optionally of one table and/or one column."""
    return tuple(t for t in TYPOS if (table is None or t.table == table) and (column is None or t.column == column))


def is_typo(table: str, angle_deg: float, column: str) -> bool:
    return any(t.table == table and t.angle_deg == angle_deg and t.column == column for t in TYPOS)
