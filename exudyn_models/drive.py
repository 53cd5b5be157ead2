"""Prescribed crank drive: smooth start-up ramp to constant speed.

Crank speed magnitude w(t) = Omega * (3 tau^2 - 2 tau^3), tau = t / T_ramp, for t < T_ramp, and
Omega afterwards (Omega = 2 pi rpm / 60). Its derivative (crank acceleration) is zero at t = 0 and at
t = T_ramp, so the drive starts without an acceleration jump. The integral over the ramp is
Omega * T_ramp / 2. The signed crank angle is

    theta(t) = theta_start + s * Omega * g(t),  g(t) = T (tau^3 - tau^4 / 2)  (t < T),
                                                g(t) = T / 2 + (t - T)         (t >= T),

with s = +1 for "ccw", -1 for "cw". theta_start = -s * Omega * T / 2 makes theta(T_ramp) = 0, so
every steady cycle k >= 1 spans t in [T + (k-1) Tc, T + k Tc] with theta = 0 at its start
(Tc = 2 pi / Omega). Crank angles are measured as in ked_quasi (CCW from M->Q). ramp_time = 0 (settings
.start = "quasi_static") is constant speed from t = 0 at crank angle 0: cycle k spans [k Tc, (k+1) Tc].
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Drive:
    """Ramp-then-constant-speed crank drive. omega [rad/s] > 0, ramp_time [s] >= 0 (0: no ramp), sign = +-1."""

    omega: float
    ramp_time: float
    sign: float

    @property
    def start_angle(self) -> float:
        """Crank angle theta(0) [rad] (unwrapped)."""
        return -self.sign * self.omega * self.ramp_time / 2.0

    @property
    def cycle_time(self) -> float:
        """Duration of one crank revolution at constant speed [s]."""
        return 2.0 * math.pi / self.omega

    def travel(self, t: float) -> float:
        """g(t) [s]: crank angle travelled divided by Omega (unsigned)."""
        T = self.ramp_time
        if t >= T:
            return 0.5 * T + (t - T)
        tau = t / T
        return T * tau**3 * (1.0 - 0.5 * tau)

    def angle(self, t: float) -> float:
        """Signed crank angle theta(t) [rad], unwrapped."""
        return self.start_angle + self.sign * self.omega * self.travel(t)

    def speed(self, t: float) -> float:
        """Signed crank speed dtheta/dt [rad/s]."""
        T = self.ramp_time
        if t >= T:
            return self.sign * self.omega
        tau = t / T
        return self.sign * self.omega * tau * tau * (3.0 - 2.0 * tau)

    def cycle_start(self, k: int) -> float:
        """Time [s] at which steady cycle k (k = 0 is the first one after the ramp) starts."""
        return self.ramp_time + k * self.cycle_time

    def user_functions(self):
        """(offset, offset_t) callables for a CoordinateConstraint on the hub rotation coordinate.

        The hub's reference rotation equals the crank angle at t = 0, so the prescribed coordinate
        is theta(t) - theta(0) = s * Omega * g(t). Kept minimal: they run every Newton iteration.
        """
        so, T = self.sign * self.omega, self.ramp_time
        half = 0.5 * T

        def offset(mbs, t, item, value):  # noqa: ARG001 - Exudyn's signature
            if t >= T:
                return so * (half + t - T)
            tau = t / T
            return so * T * tau * tau * tau * (1.0 - 0.5 * tau)

        def offset_t(mbs, t, item, value):  # noqa: ARG001
            if t >= T:
                return so
            tau = t / T
            return so * tau * tau * (3.0 - 2.0 * tau)

        return offset, offset_t
