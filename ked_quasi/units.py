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


def omega1_min(f1_hz) -> float:
    """omega1_min [rad/s]: 2 pi times the lowest first frozen natural frequency [Hz] over the crank angles
    (NaN entries ignored), the reference of the speed ratio."""
    import numpy as np

    return 2.0 * math.pi * float(np.nanmin(np.asarray(f1_hz, dtype=float)))


def speed_ratio(omega: float, omega1: float) -> float:
    """The speed ratio r = Omega / omega1_min [1] of a crank speed ``omega`` [rad/s, either sign] and the lowest
    first frozen natural circular frequency ``omega1`` [rad/s]; NaN when either is unknown or omega1 <= 0."""
    if not (math.isfinite(omega) and math.isfinite(omega1) and omega1 > 0.0):
        return math.nan
    return abs(omega) / omega1
