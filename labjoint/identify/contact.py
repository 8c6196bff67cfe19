"""Contact pressure under a bolt and its closed-form integrals (seed 002 Eqs. 2-3, 6).

seed 002 Eq. 2 with Table 1, signs ALTERNATING (correction in seeds/README.md)::

    sigma / sigma_s = A0 - A1 x^2 + A2 x^4 - A3 x^6 + A4 x^8 - A5 x^10,   x = r / r_b

The printed all-positive signs would make the pressure grow outwards; with alternating
signs it falls to zero at x0 = 3.49932, i.e. at the paper's contact boundary
a = 3.5 r_b to the table's five digits. The pressure is taken as zero on the sliver
x0 < x <= 3.5 (where the truncated polynomial dips to -2e-4), so every integral is
monotone in the lower radius.

With y = x^2 the ring integral is a polynomial in y (r dr = r_b^2 dy / 2)::

    int_c^a sigma 2 pi r dr = pi sigma_s r_b^2 [G(y0) - G(y_c)],
    G(y) = sum_n (-1)^n A_n y^(n+1) / (n+1)

``sigma_s`` (the "applied stress under the bolt head"): by default it is NORMALISED so
that the pressure integrated over the contact zone (inner radius .. a) equals the bolt
normal force (equilibrium), which makes the whole patch's friction capacity mu N.
``sigma_s_mode="head"`` takes the paper literally (N / area under the head) instead;
:attr:`ContactPressure.force_ratio` then reports how far the integrated pressure is
from N.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from labjoint.errors import InputError

#: seed 002 Table 1, with the alternating signs of Eq. 2 (seeds/README.md).
PRESSURE_COEFFICIENTS: tuple[float, ...] = (
    0.68517, -0.10122, 0.94205e-2, -0.23895e-2, 0.29487e-3, -0.11262e-4)
#: seed 002: contact boundary a = 3.5 r_b.
CONTACT_RATIO = 3.5
SIGMA_S_MODES = ("force", "head")

_A = np.asarray(PRESSURE_COEFFICIENTS)
_P = np.polynomial.Polynomial(_A)          # P(y) = sigma/sigma_s at x^2 = y
_G = _P.integ()                            # G(y), G(0) = 0


def _pressure_zero_y() -> float:
    """First positive real root (in y = x^2) of Eq. 2's polynomial: x0^2."""
    roots = _P.roots()
    real = np.sort(roots[(np.abs(roots.imag) < 1e-9) & (roots.real > 0)].real)
    return float(real[0])


Y_ZERO = _pressure_zero_y()
#: Radius ratio where Eq. 2 (alternating signs) reaches zero: 3.49932.
X_ZERO = float(np.sqrt(Y_ZERO))


def pressure_ratio(x: np.ndarray | float) -> np.ndarray:
    """sigma / sigma_s at x = r / r_b (seed 002 Eq. 2, alternating signs), zero past x0.

    >>> float(np.round(pressure_ratio(0.0), 5)), float(pressure_ratio(3.6))
    (0.68517, 0.0)
    """
    x = np.asarray(x, dtype=float)
    y = x * x
    return np.where(y < Y_ZERO, _P(np.minimum(y, Y_ZERO)), 0.0)


def _require(ok: bool, message: str, field: str) -> None:
    if not ok:
        raise InputError(message, field=field)


@dataclass(frozen=True)
class ContactPressure:
    """Eq. 2 pressure field of one bolt: geometry, normal force and its integrals.

    Radii in m, force in N. ``contact_radius_m`` defaults to a = 3.5 r_b (seed 002);
    ``inner_radius_m`` bounds the contact zone inwards: default 0, the full circular
    area seed 002 assumes (Sec. IV.D), as the simulator does; give the hole radius
    (about r_b) to exclude the bolt hole.

    >>> cp = ContactPressure(bolt_radius_m=4e-3, normal_force_n=2390.0)
    >>> round(float(cp.capacity(cp.inner)), 6)
    2390.0
    >>> float(cp.capacity(cp.a))
    0.0
    """

    bolt_radius_m: float
    normal_force_n: float
    contact_radius_m: float | None = None
    inner_radius_m: float | None = None
    head_radius_m: float | None = None
    sigma_s_mode: str = "force"
    table_size: int = 4097

    def __post_init__(self) -> None:
        rb = self.bolt_radius_m
        _require(np.isfinite(rb) and rb > 0, f"bolt radius must be positive, got {rb} m",
                 "bolt_radius_m")
        _require(np.isfinite(self.normal_force_n) and self.normal_force_n > 0,
                 f"normal force must be positive, got {self.normal_force_n} N (torque 0?)",
                 "normal_force_n")
        a = self.contact_radius_m
        if a is not None:
            _require(np.isfinite(a) and a > rb,
                     f"contact radius a must exceed the bolt radius r_b = {rb} m, got {a} m",
                     "contact_radius_m")
            _require(a <= CONTACT_RATIO * rb * (1 + 1e-12),
                     f"contact radius a = {a} m lies beyond Eq. 2's pressure zero "
                     f"({CONTACT_RATIO} r_b = {CONTACT_RATIO * rb} m)", "contact_radius_m")
        ri = self.inner_radius_m
        if ri is not None:
            _require(np.isfinite(ri) and 0 <= ri < self.a,
                     f"inner contact radius must lie in [0, a = {self.a} m), got {ri} m",
                     "inner_radius_m")
        _require(self.sigma_s_mode in SIGMA_S_MODES,
                 f"sigma_s_mode must be one of {SIGMA_S_MODES}, got {self.sigma_s_mode!r}",
                 "sigma_s_mode")
        rh = self.head_radius_m
        if rh is not None:
            _require(np.isfinite(rh) and rh > self.inner,
                     f"bolt-head radius must exceed the inner radius {self.inner} m, "
                     f"got {rh} m", "head_radius_m")
        if self.sigma_s_mode == "head":
            _require(rh is not None, "sigma_s_mode='head' needs the bolt-head radius",
                     "head_radius_m")
        _require(int(self.table_size) >= 64, "table_size must be >= 64", "table_size")

    # ---- geometry ----------------------------------------------------------------
    @property
    def a(self) -> float:
        """Contact-zone outer radius a (m)."""
        return CONTACT_RATIO * self.bolt_radius_m if self.contact_radius_m is None \
            else float(self.contact_radius_m)

    @property
    def inner(self) -> float:
        """Contact-zone inner radius (m): 0 (full disc) unless given."""
        return 0.0 if self.inner_radius_m is None else float(self.inner_radius_m)

    @property
    def _y_top(self) -> float:
        return min((self.a / self.bolt_radius_m) ** 2, Y_ZERO)

    @property
    def _y_in(self) -> float:
        return (self.inner / self.bolt_radius_m) ** 2

    def _g_above(self, y: np.ndarray) -> np.ndarray:
        """Dimensionless G(y_top) - G(y) for y <= y_top (0 above)."""
        y = np.minimum(y, self._y_top)
        return _G(self._y_top) - _G(y)

    # ---- sigma_s -----------------------------------------------------------------
    @cached_property
    def sigma_s_head(self) -> float | None:
        """Paper-literal sigma_s = N / (area under the head) (Pa), if the head is known."""
        if self.head_radius_m is None:
            return None
        area = np.pi * (self.head_radius_m ** 2 - self.inner ** 2)
        return float(self.normal_force_n / area)

    @cached_property
    def sigma_s(self) -> float:
        """sigma_s used (Pa): normalised to N (default) or the head stress (mode 'head')."""
        if self.sigma_s_mode == "head":
            return float(self.sigma_s_head)
        integ = np.pi * self.bolt_radius_m ** 2 * float(self._g_above(np.array(self._y_in)))
        return self.normal_force_n / integ

    @property
    def force_ratio(self) -> float | None:
        """(pressure integrated over the contact zone with the head stress) / N."""
        if self.sigma_s_head is None:
            return None
        integ = np.pi * self.bolt_radius_m ** 2 * float(self._g_above(np.array(self._y_in)))
        return self.sigma_s_head * integ / self.normal_force_n

    # ---- fields and integrals ----------------------------------------------------
    def pressure(self, r: np.ndarray | float) -> np.ndarray:
        """Contact pressure sigma(r) (Pa), Eq. 2; zero outside [inner, a]."""
        r = np.asarray(r, dtype=float)
        inside = (r >= self.inner) & (r <= self.a)
        return np.where(inside, self.sigma_s * pressure_ratio(r / self.bolt_radius_m), 0.0)

    def capacity(self, c: np.ndarray | float) -> np.ndarray:
        """int_c^a sigma 2 pi r dr (N): normal load on the annulus c..a (Eq. 3 / mu)."""
        y = (np.clip(np.asarray(c, dtype=float), self.inner, self.a) / self.bolt_radius_m) ** 2
        return np.pi * self.sigma_s * self.bolt_radius_m ** 2 * self._g_above(y)

    @property
    def total_force(self) -> float:
        """Pressure integrated over the whole contact zone (N); = N unless mode 'head'."""
        return float(self.capacity(self.inner))

    @cached_property
    def _table(self) -> np.ndarray:
        """y at uniformly spaced s = sqrt(G(y_top) - G(y)), s = 0 .. s_max.

        In s the inverse is smooth even at the outer edge, where the pressure (the
        derivative) vanishes and G(y_top) - G(y) ~ (y_top - y)^2; uniform spacing
        makes the lookup O(1). Built from a dense monotone table in y.
        """
        n = int(self.table_size)
        y = np.linspace(self._y_top, self._y_in, 4 * n)
        s = np.maximum.accumulate(np.sqrt(np.maximum(self._g_above(y), 0.0)))
        return np.interp(np.linspace(0.0, s[-1], n), s, y)

    @property
    def load_scale(self) -> float:
        """pi sigma_s r_b^2 (N): capacity(c) = load_scale (G(y_top) - G(y_c))."""
        return float(np.pi * self.sigma_s * self.bolt_radius_m ** 2)

    def solver_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(table, meta = [y_in, y_top, G(y_top)], coefs = P, 0, G) for :func:`invert_loads`."""
        meta = np.array([self._y_in, self._y_top, float(_G(self._y_top))])
        return self._table, meta, np.concatenate([_P.coef, [0.0], _G.coef])

    def radius_for_load(self, load: np.ndarray | float, newton_steps: int = 1
                        ) -> tuple[np.ndarray, np.ndarray]:
        """Radius c with capacity(c) = load (N), vectorised; and a flag load > total.

        Uniform-table interpolation plus safeguarded Newton steps on
        sqrt(G(y_top) - G(y)) = sqrt(h) (numba). ``load <= 0`` gives c = a; a load
        beyond the whole patch clamps c to the inner radius (flag True: macro-slip).
        """
        h = np.ascontiguousarray(np.asarray(load, dtype=float) / self.load_scale).ravel()
        y = np.empty_like(h)
        over = np.empty(h.shape, dtype=np.bool_)
        table, meta, coefs = self.solver_arrays()
        invert_loads(h, table, meta, coefs, int(newton_steps), y, over)
        c = self.bolt_radius_m * np.sqrt(y)
        c = np.where(h <= 0, self.a, c)
        shape = np.shape(load)
        return c.reshape(shape), over.reshape(shape)


@njit(cache=True)
def horner(c: np.ndarray, lo: int, hi: int, y: float) -> float:
    r = 0.0
    for k in range(hi - 1, lo - 1, -1):
        r = r * y + c[k]
    return r


@njit(cache=True)
def invert_loads(h, table, meta, coefs, newton_steps, y_out, over_out):  # pragma: no cover
    """y = (c / r_b)^2 with G(y_top) - G(y) = h for every h (numba; see radius_for_load).

    ``coefs`` = P coefficients (6), a 0 separator, G coefficients (7).
    """
    y_in, y_top, g_top = meta[0], meta[1], meta[2]
    m = table.size
    s_max2 = g_top - horner(coefs, 7, 14, y_in)
    s_max = np.sqrt(max(s_max2, 0.0))
    ds = s_max / (m - 1)
    for i in range(h.size):
        hi = h[i]
        if hi <= 0.0:
            y_out[i] = y_top
            over_out[i] = False
            continue
        if hi > s_max2:
            y_out[i] = y_in
            over_out[i] = True
            continue
        over_out[i] = False
        st = np.sqrt(hi)
        x = st / ds
        j = min(int(x), m - 2)
        t = x - j
        y = table[j] + t * (table[j + 1] - table[j])
        for _ in range(newton_steps):
            g = g_top - horner(coefs, 7, 14, y)
            p = horner(coefs, 0, 6, y)
            if g > 0.0 and p > 0.0:
                sq = np.sqrt(g)
                y = y + (sq - st) * 2.0 * sq / p
                y = min(max(y, y_in), y_top)
        y_out[i] = y
