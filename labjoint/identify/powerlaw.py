"""A power law y = a x^n fitted on log axes: the dissipation exponent of seed 001.

Seed 001 (Iwan models): Segalman's four-parameter joint dissipates per cycle
Delta W ~ F^(3 + chi) under a force amplitude F; micro-slip tests find the exponent
between 2.5 and 3 (chi < 0), a viscous joint has 2. The exponent is the slope of
ln W against ln F, found here by weighted least squares: the weight of a point is
1 / (u_y / y)^2, the variance of ln y propagated from y's standard uncertainty u_y.

Its standard error comes from the stated uncertainties, widened by the scatter about
the line when that is larger (the covariance is scaled by max(1, chi^2 / dof)): a power
law is an approximation, and its misfit belongs in the interval. Without usable
uncertainties every point weighs the same and the scatter alone sets the error. The
95 % interval uses Student's t with n - 2 degrees of freedom.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Sequence

import numpy as np
from scipy import stats

from labjoint.errors import InputError

#: Fewest distinct amplitudes an exponent is fitted from (2 fix a line exactly).
MIN_AMPLITUDES = 3
#: Amplitudes closer than this (relative) count as one setting (repeats of a level).
DISTINCT_RTOL = 0.01
#: Seed 001's measured range of the exponent 3 + chi in micro-slip.
SEGALMAN_RANGE = (2.5, 3.0)


@dataclass(frozen=True)
class PowerLawFit:
    """y = coefficient * x ** exponent, with the exponent's standard error and interval."""

    exponent: float
    exponent_stderr: float
    exponent_ci95: tuple[float, float]
    coefficient: float
    n_points: int
    n_amplitudes: int
    dof: int
    chi2_reduced: float
    weighted: bool

    def predict(self, x: Any) -> np.ndarray:
        """The fitted y at ``x``."""
        return self.coefficient * np.asarray(x, dtype=float) ** self.exponent

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["exponent_ci95"] = list(self.exponent_ci95)
        return d


def distinct_amplitudes(x: Sequence[float], rtol: float = DISTINCT_RTOL) -> int:
    """How many settings ``x`` holds, values within ``rtol`` of the previous one merged.

    >>> distinct_amplitudes([2.0, 2.01, 4.0, 8.0, 8.0])
    3
    """
    lx = np.sort(np.log(np.asarray(x, dtype=float)))
    return int(1 + np.count_nonzero(np.diff(lx) > np.log1p(rtol))) if lx.size else 0


def _positive(values: Any, name: str) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if v.ndim != 1:
        raise InputError(f"must be a 1-D sequence, got shape {v.shape}", field=name)
    bad = np.flatnonzero(~np.isfinite(v) | (v <= 0))
    if bad.size:
        raise InputError(f"must be positive and finite for a log-log fit; entry {int(bad[0])} "
                         f"is {float(v[bad[0]]):g}", field=name)
    return v


def fit_power_law(x: Sequence[float], y: Sequence[float],
                  u_y: Sequence[float | None] | None = None, *, x_name: str = "x",
                  y_name: str = "y", confidence: float = 0.95) -> PowerLawFit:
    """Fit y = a x^n by weighted least squares of ln y on ln x (module doc).

    Refuses (InputError naming ``x_name``) fewer than ``MIN_AMPLITUDES`` distinct x.

    >>> fit = fit_power_law([1.0, 2.0, 4.0, 8.0], [3 * v ** 2.5 for v in (1, 2, 4, 8)])
    >>> round(fit.exponent, 6), round(fit.coefficient, 6)
    (2.5, 3.0)
    """
    xs, ys = _positive(x, x_name), _positive(y, y_name)
    if xs.size != ys.size:
        raise InputError(f"has {xs.size} values but {y_name} has {ys.size}", field=x_name)
    k = distinct_amplitudes(xs)
    if k < MIN_AMPLITUDES:
        raise InputError(f"has {k} distinct amplitude{'s' * (k != 1)} "
                         f"({', '.join(f'{v:.4g}' for v in sorted(set(xs.tolist())))}); a "
                         f"power-law exponent needs at least {MIN_AMPLITUDES} (two points fix "
                         "any line, so they give no exponent with an uncertainty)", field=x_name)
    if not 0 < confidence < 1:
        raise InputError(f"must be between 0 and 1, got {confidence}", field="confidence")
    weighted = False
    w = np.ones_like(ys)
    if u_y is not None:
        u = np.array([np.nan if v is None else v for v in u_y], dtype=float)
        if u.size != ys.size:
            raise InputError(f"has {u.size} values but {y_name} has {ys.size}",
                             field=f"{y_name} uncertainty")
        if np.all(np.isfinite(u) & (u > 0)):
            w, weighted = (ys / u) ** 2, True
    if weighted and not np.all(np.isfinite(w)):
        w, weighted = np.ones_like(ys), False       # an uncertainty of ~0: weights unusable
    # centred on the weighted mean of ln x, the slope's variance is 1 / sum w (ln x - mean)^2
    # (the normal equations of ln x and 1 uncoupled: no cancellation, never negative)
    lx, z = np.log(xs), np.log(ys)
    mx = float(np.sum(w * lx) / np.sum(w))
    xc = lx - mx
    sxx = float(np.sum(w * xc ** 2))
    if not (np.isfinite(sxx) and sxx > 0):
        raise InputError("the amplitudes are too close together to fit an exponent", field=x_name)
    n = float(np.sum(w * xc * z) / sxx)
    a0 = float(np.sum(w * z) / np.sum(w)) - n * mx
    dof = xs.size - 2
    chi2_red = float(np.sum(w * (z - a0 - n * lx) ** 2) / dof)
    scale = max(1.0, chi2_red) if weighted else chi2_red
    se = float(np.sqrt(scale / sxx))
    half = float(stats.t.ppf(0.5 + confidence / 2, dof)) * se
    return PowerLawFit(exponent=n, exponent_stderr=se, exponent_ci95=(n - half, n + half),
                       coefficient=float(np.exp(a0)), n_points=int(xs.size),
                       n_amplitudes=k, dof=int(dof), chi2_reduced=chi2_red, weighted=weighted)
