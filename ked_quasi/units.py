"""Inch-pound <-> SI conversion factors, used only at the edges (thesis data in, table output).

All code inside the harness works in SI (m, kg, N, s, rad).
"""

import math

INCH = 0.0254  # m per inch (exact)
POUND_MASS = 0.45359237  # kg per lbm (exact)
POUND_FORCE = 4.4482216152605  # N per lbf (exact)
PSI = POUND_FORCE / INCH**2  # Pa per psi
G0 = 9.80665  # m/s^2, standard gravity (1 lb weight <-> 1 lbm)


def rpm_to_rad_s(rpm: float) -> float:
    """Crank speed in rev/min -> rad/s."""
    return rpm * 2.0 * math.pi / 60.0


def rad_s_to_rpm(omega: float) -> float:
    """Crank speed in rad/s -> rev/min."""
    return omega * 60.0 / (2.0 * math.pi)
