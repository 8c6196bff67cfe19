"""Contact pressure of the bolted lap joint and its discretisation into Iwan rings.

Seed 002 Eq. 2 gives the interface pressure as a polynomial in x = r / r_b with the
coefficients of its Table 1. Table 1 prints A0..A5 all positive; the pressure only falls
to zero at the contact boundary a = 3.5 r_b (as the paper states) when the signs
alternate (seed README correction), so this module uses

    sigma / sigma_s = A0 - A1 x^2 + A2 x^4 - A3 x^6 + A4 x^8 - A5 x^10.

``sigma_s`` is fixed so that the pressure integrated over the contact disc 0 <= r <= a
equals the bolt normal force N (itself 478 N per Nm of torque, seed 002 Sec. IV-A):

    N = 2 pi sigma_s r_b^2 * integral_0^(a/r_b) p(x) x dx.

The disc is cut into concentric rings; ring i is a Jenkins element (shear-layer spring
in series with a Coulomb slider, seed 002 Eq. 4) with stiffness k_tau dA_i and slip
force mu * integral_ring sigma dA (seed 002 Eq. 3). The outer rings carry less pressure,
so they slip first: the micro-slip annulus grows inwards from r = a.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labjoint.errors import ConfigError

#: Seed 002 Table 1, A0..A5 (magnitudes as printed).
TABLE1 = np.array([0.68517, 0.10122, 0.94205e-2, 0.23895e-2, 0.29487e-3, 0.11262e-4])
#: Signed coefficients of Eq. 2 (alternating signs, see module docstring).
COEFFS = TABLE1 * np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
#: Seed 002: contact boundary at a = 3.5 r_b.
CONTACT_RATIO = 3.5
#: Seed 002 Sec. IV-A: bolt normal force per Nm of tightening torque.
NEWTON_PER_NM = 478.0


def _positive(value: float, field: str, unit: str) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise ConfigError(f"must be a positive finite number ({unit}), got {value!r}", field=field)
    return v


def pressure_ratio(x: np.ndarray | float) -> np.ndarray:
    """sigma/sigma_s at x = r/r_b (seed 002 Eq. 2, Table 1, alternating signs).

    >>> round(float(pressure_ratio(0.0)), 5)
    0.68517
    >>> abs(float(pressure_ratio(3.5))) < 1e-3
    True
    """
    x2 = np.asarray(x, dtype=float) ** 2
    out = np.zeros_like(x2)
    for c in COEFFS[::-1]:
        out = out * x2 + c
    return out


def _moment(x: np.ndarray | float) -> np.ndarray:
    """Antiderivative of p(x) x: sum_n c_n x^(2n+2) / (2n+2)."""
    x = np.asarray(x, dtype=float)
    return sum(COEFFS[n] * x ** (2 * n + 2) / (2 * n + 2) for n in range(len(COEFFS)))


def normal_force(torque_nm: float, newton_per_nm: float = NEWTON_PER_NM) -> float:
    """Bolt normal force (N) from tightening torque (seed 002: 478 N/Nm)."""
    return _positive(torque_nm, "torque_nm", "Nm") * _positive(newton_per_nm, "torque_to_normal_n_per_nm", "N/Nm")


def bolt_stress(normal_force_n: float, bolt_radius_m: float, contact_ratio: float = CONTACT_RATIO) -> float:
    """sigma_s (Pa) such that 2 pi int_0^a sigma r dr = N (Eq. 2 normalised to the bolt load)."""
    n = _positive(normal_force_n, "normal_force_n", "N")
    rb = _positive(bolt_radius_m, "contact.bolt_radius_m", "m")
    ratio = _check_ratio(contact_ratio)
    return n / (2.0 * np.pi * rb**2 * float(_moment(ratio)))


def _check_ratio(contact_ratio: float) -> float:
    ratio = _positive(contact_ratio, "contact.contact_ratio", "a / r_b")
    if ratio <= 1.0:
        raise ConfigError(f"contact boundary a must exceed the bolt radius (a / r_b > 1), got {contact_ratio}",
                          field="contact.contact_ratio")
    return ratio


def pressure(r: np.ndarray | float, normal_force_n: float, bolt_radius_m: float,
             contact_ratio: float = CONTACT_RATIO) -> np.ndarray:
    """Contact pressure sigma(r) in Pa (seed 002 Eq. 2); zero outside r > a.

    The polynomial dips a few 1e-4 sigma_s below zero just inside a (Table 1 rounding);
    this function returns it unclipped inside a so integrals match the normalisation.
    """
    sig_s = bolt_stress(normal_force_n, bolt_radius_m, contact_ratio)
    r = np.asarray(r, dtype=float)
    x = r / bolt_radius_m
    return np.where(x <= contact_ratio, sig_s * pressure_ratio(x), 0.0)


def integrated_force(r_in: float, r_out: float, normal_force_n: float, bolt_radius_m: float,
                     contact_ratio: float = CONTACT_RATIO) -> float:
    """2 pi int_{r_in}^{r_out} sigma r dr in N (exact, from the polynomial's antiderivative)."""
    sig_s = bolt_stress(normal_force_n, bolt_radius_m, contact_ratio)
    a = contact_ratio * bolt_radius_m
    lo, hi = np.clip([r_in, r_out], 0.0, a) / bolt_radius_m
    return float(2.0 * np.pi * sig_s * bolt_radius_m**2 * (_moment(hi) - _moment(lo)))


def sliding_force(c: float, mu: float, normal_force_n: float, bolt_radius_m: float,
                  contact_ratio: float = CONTACT_RATIO) -> float:
    """Friction force of the sliding annulus c <= r <= a (seed 002 Eq. 3)."""
    a = contact_ratio * bolt_radius_m
    return _positive(mu, "contact.friction_coefficient", "1") * integrated_force(
        c, a, normal_force_n, bolt_radius_m, contact_ratio)


@dataclass(frozen=True)
class Rings:
    """The contact disc as concentric Jenkins rings, outermost last.

    ``slip_force`` (N) = mu int_ring sigma dA; ``stiffness`` (N/m) = k_tau dA with k_tau the
    shear-layer stiffness per unit area; ``slip_displacement`` = slip_force / stiffness
    (m), which falls towards the edge so outer rings slip first.
    """

    r_in: np.ndarray
    r_out: np.ndarray
    area: np.ndarray
    slip_force: np.ndarray
    stiffness: np.ndarray

    @property
    def r_mid(self) -> np.ndarray:
        return 0.5 * (self.r_in + self.r_out)

    @property
    def slip_displacement(self) -> np.ndarray:
        return self.slip_force / self.stiffness

    def backbone(self, u: np.ndarray | float) -> np.ndarray:
        """Virgin loading curve F(u) = sum_i min(k_i |u|, f_i) sgn(u) (N)."""
        u = np.asarray(u, dtype=float)
        f = np.minimum(np.abs(u)[..., None] * self.stiffness, self.slip_force).sum(axis=-1)
        return np.sign(u) * f

    def dissipation(self, amplitude_m: float) -> float:
        """Energy per symmetric cycle of displacement amplitude U: sum 4 f_i (U - f_i/k_i)^+ (J)."""
        return float(np.sum(4.0 * self.slip_force * np.clip(amplitude_m - self.slip_displacement, 0.0, None)))


def zero_pressure_ratio(contact_ratio: float = CONTACT_RATIO) -> float:
    """Where the contact really ends: the first zero of Eq. 2 in x, capped at a / r_b.

    With Table 1 this is x = 3.4993, i.e. a = 3.5 r_b to the table's precision; rings stop
    there so none of them lies where the rounded polynomial turns slightly negative.
    """
    y = np.roots(COEFFS[::-1])
    y = np.sort(y[(np.abs(y.imag) < 1e-12) & (y.real > 0)].real)
    x0 = float(np.sqrt(y[0])) if len(y) else np.inf
    return min(x0, float(contact_ratio))


def ring_edges(n_rings: int, outer_radius_m: float, edge_refinement: float = 1e-4) -> np.ndarray:
    """Ring boundaries 0 = r_0 < ... < r_n = a, geometrically finer towards the edge.

    The distance from the edge d = a - r grows geometrically from ``edge_refinement * a``
    to ``a``, so the slip threshold (which falls linearly to zero at the edge) is resolved
    down to small amplitudes.
    """
    if int(n_rings) != n_rings or n_rings < 2:
        raise ConfigError(f"need at least 2 rings, got {n_rings!r}", field="contact.rings")
    if not 0.0 < edge_refinement < 1.0:
        raise ConfigError(f"must be in (0, 1), got {edge_refinement!r}", field="contact.edge_refinement")
    n = int(n_rings)
    d = edge_refinement * outer_radius_m * (1.0 / edge_refinement) ** (np.arange(n) / (n - 1))
    edges = outer_radius_m - np.concatenate([[0.0], d])[::-1]
    edges[0] = 0.0
    return edges


def make_rings(*, normal_force_n: float, bolt_radius_m: float, friction_coefficient: float,
               shear_stiffness_n_per_m: float, n_rings: int = 60, contact_ratio: float = CONTACT_RATIO,
               edge_refinement: float = 1e-4) -> Rings:
    """Discretise the contact (Eq. 2 pressure, Eq. 3 friction, Eq. 4 shear layer) into rings.

    ``shear_stiffness_n_per_m`` is the total tangential stiffness of the shear layer over
    the contact disc (the joint's sticking stiffness); it is spread uniformly per area.
    The rings cover 0 <= r <= x0 r_b with x0 the first zero of Eq. 2 (3.4993 for
    a = 3.5 r_b); their slip forces sum to mu N (to 1e-7: the rounded polynomial's
    negative sliver between x0 and 3.5 is left out).

    >>> rings = make_rings(normal_force_n=2390.0, bolt_radius_m=5e-3, friction_coefficient=0.168,
    ...                    shear_stiffness_n_per_m=14e6)
    >>> round(float(rings.slip_force.sum()), 1), round(float(rings.stiffness.sum()) / 1e6, 3)
    (401.5, 14.0)
    """
    rb = _positive(bolt_radius_m, "contact.bolt_radius_m", "m")
    ratio = _check_ratio(contact_ratio)
    mu = _positive(friction_coefficient, "contact.friction_coefficient", "1")
    kt = _positive(shear_stiffness_n_per_m, "contact.shear_stiffness_n_per_m", "N/m")
    n = _positive(normal_force_n, "normal_force_n", "N")
    a = zero_pressure_ratio(ratio) * rb
    edges = ring_edges(n_rings, a, edge_refinement)
    sig_s = bolt_stress(n, rb, ratio)
    load = 2.0 * np.pi * sig_s * rb**2 * np.diff(_moment(edges / rb))
    area = np.pi * np.diff(edges**2)
    k_tau = kt / (np.pi * a**2)
    return Rings(r_in=edges[:-1], r_out=edges[1:], area=area,
                 slip_force=mu * np.clip(load, 0.0, None), stiffness=k_tau * area)
