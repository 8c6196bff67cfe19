"""Seed 002's stick-slip boundary along rising quarter cycles (Eqs. 5-9), vectorised: the
curves c(u), f_sld(u), W(u), C(u), K(u) that :mod:`labjoint.identify.stickslip` turns into
a run's result (its module docstring gives the equations and what the numbers are)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from labjoint.errors import InputError
from labjoint.identify.contact import ContactPressure, horner, invert_loads

#: Friction coefficients taken: far below (above) any dry contact's (mu -> 0: Eq. 6 overflows)
MIN_FRICTION, MAX_FRICTION = 1e-3, 5.0


def check_friction(mu: float, field: str = "friction_coefficient") -> float:
    """``mu`` as a float if it is a friction coefficient a contact can have, else InputError."""
    mu = float(mu)
    if not (np.isfinite(mu) and MIN_FRICTION <= mu <= MAX_FRICTION):
        raise InputError(f"friction coefficient must be between {MIN_FRICTION:g} and "
                         f"{MAX_FRICTION:g}, got {mu:g}", field=field)
    return float(mu)


def _check_inputs(k_t: float, mu: float, frequency_hz: float) -> None:
    check_friction(mu)
    if not (np.isfinite(k_t) and k_t > 0):
        raise InputError(f"shear-layer stiffness K_t must be positive, got {k_t} N/m",
                         field="shear_stiffness_n_per_m")
    if not (np.isfinite(frequency_hz) and frequency_hz > 0):
        raise InputError(f"excitation frequency must be positive, got {frequency_hz} Hz",
                         field="frequency_hz")


@dataclass
class QuarterCurves:
    """Eqs. 6-9 along one or more rising quarter cycles, stored flat.

    Quarter k occupies ``[starts[k], starts[k+1])`` of every per-sample array
    (``starts`` has one more entry than there are quarters). Units: m, J, N s/m, N/m, N.
    """

    displacement_m: np.ndarray
    boundary_radius_m: np.ndarray
    sliding_force_n: np.ndarray
    energy_loss_j: np.ndarray        # cumulative: W(u_i) = sum_{k<=i} W_dk, full cycle
    damping_ns_per_m: np.ndarray
    stiffness_n_per_m: np.ndarray
    macro_slip: np.ndarray
    starts: np.ndarray

    @property
    def n_quarters(self) -> int:
        return len(self.starts) - 1

    @property
    def ends(self) -> np.ndarray:
        """Index of each quarter's last sample (u_n = U)."""
        return self.starts[1:] - 1

    def quarter(self, k: int) -> dict[str, np.ndarray]:
        """The curves of quarter ``k`` as a dict of arrays."""
        sl = slice(int(self.starts[k]), int(self.starts[k + 1]))
        return {name: getattr(self, name)[sl] for name in
                ("displacement_m", "boundary_radius_m", "sliding_force_n", "energy_loss_j",
                 "damping_ns_per_m", "stiffness_n_per_m", "macro_slip")}

    def totals(self) -> dict[str, np.ndarray]:
        """Per quarter: amplitude U, energy loss per cycle W, damping C, macro-slip flag."""
        e = self.ends
        macro = np.logical_or.reduceat(self.macro_slip, self.starts[:-1]) \
            if self.n_quarters else np.zeros(0, bool)
        return {"displacement_amplitude_m": self.displacement_m[e],
                "energy_loss_j": self.energy_loss_j[e],
                "damping_ns_per_m": self.damping_ns_per_m[e],
                "min_boundary_radius_m": self.boundary_radius_m[e],
                "macro_slip": macro}


def stick_slip_curves(displacement_m: np.ndarray, starts: np.ndarray | None, *,
                      shear_stiffness_n_per_m: float, friction_coefficient: float,
                      contact: ContactPressure, frequency_hz: float) -> QuarterCurves:
    """Eqs. 6-9 on rising quarter cycles given flat; each must start at u_1 = 0 (Eq. 5).

    ``starts``: first index of each quarter in ``displacement_m`` (None: one quarter).
    The example is seed 002's reference case: K = 2 K_t = 11.8 MN/m, U = 7.4 um, 400 Hz:
    W = 2 K_t U^2 and C = K / (pi omega) exactly, at any sampling (Table 2's 0.672 mJ and
    1542 Ns/m are its right-endpoint sums, 1.03-1.04 times these).

    >>> cp = ContactPressure(bolt_radius_m=4e-3, normal_force_n=2390.0)
    >>> u = 7.4e-6 * np.sin(np.linspace(0, np.pi / 2, 32))
    >>> q = stick_slip_curves(u, None, shear_stiffness_n_per_m=5.9e6,
    ...                       friction_coefficient=0.168, contact=cp, frequency_hz=400.0)
    >>> W, C = float(q.energy_loss_j[-1]), float(q.damping_ns_per_m[-1])
    >>> round(W * 1e3, 4), round(C / (11.8e6 / (np.pi * 2 * np.pi * 400)), 9)
    (0.6462, 1.0)
    """
    k_t, mu = float(shear_stiffness_n_per_m), float(friction_coefficient)
    _check_inputs(k_t, mu, frequency_hz)
    u = np.ascontiguousarray(displacement_m, dtype=float)
    n = u.size
    starts = np.array([0, n] if starts is None else np.append(starts, n), dtype=np.int64)
    if n == 0 or np.any(np.diff(starts) < 1) or starts[0] != 0:
        raise InputError("quarter-cycle starts must be increasing indices from 0",
                         field="starts")
    # Eq. 6 -> y_i = (c_i / r_b)^2 for every sample at once; macro-slip when K_t u_i
    # exceeds mu * (whole-patch load): c_i then clamps to the inner radius.
    y = np.empty(n)
    macro = np.empty(n, dtype=np.bool_)
    table, meta, coefs = contact.solver_arrays()
    invert_loads(k_t * u / (mu * contact.load_scale), table, meta, coefs, 1, y, macro)
    c = np.where(u > 0, contact.bolt_radius_m * np.sqrt(y), contact.a)
    out = np.empty((4, n))
    _eqs_7_to_9(u, starts, y, coefs, meta[2], mu * contact.load_scale, k_t,
                mu * contact.total_force, 2.0 * np.pi * frequency_hz, out)
    f_sld, w, damping, stiffness = out
    return QuarterCurves(u, c, f_sld, w, damping, stiffness, macro, starts)


@njit(cache=True)
def _eqs_7_to_9(u, starts, y, coefs, g_top, mu_scale, k_t, f_max, omega, out):  # pragma: no cover
    """Per sample: f_sld (Eq. 3 at c_i), W (Eq. 7 integrated exactly), C (Eq. 8), K (Eq. 9)."""
    u_star = f_max / k_t                                       # macro-slip from here on
    for i in range(u.size):
        g = 0.0
        if u[i] > 0.0:
            g = g_top - horner(coefs, 7, 14, y[i])
        f_sld = mu_scale * g                                   # Eq. 3
        x = max(u[i], 0.0)
        if x <= u_star:                                        # 4 int_0^x K_t s ds
            w = 2.0 * k_t * x * x
        else:                                                  # + 4 f_max (x - u*)
            w = 2.0 * k_t * u_star * u_star + 4.0 * f_max * (x - u_star)
        out[0, i] = f_sld
        out[1, i] = w
        if x > 0.0:
            out[2, i] = w / (np.pi * omega * x * x)            # Eq. 8
            if x <= u_star:
                out[3, i] = 2.0 * k_t                          # Eq. 9: (K_t u + K_t u) / u
            else:
                out[3, i] = f_max / x                          # all slides: f_max, once
        else:
            out[2, i] = 0.0
            out[3, i] = 2.0 * k_t
