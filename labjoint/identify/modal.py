"""Modal parameters (natural frequency, damping ratio) of measured FRFs.

Two estimators side by side, per sweep (force level, direction) of an
:class:`~labjoint.signal.frfset.FrfSet`:

- LSCF poles with LSFD modal constants, by sdypy-ema (``sdypy.EMA.Model``), over every
  response sensor at once; the pole nearest the FRF's peak is taken from the
  stabilisation of increasing model orders. A step-sine grid that is not uniform, or not
  on whole multiples of its spacing, is interpolated onto one that is first, and the
  lines below the band are given as zeros from 0 Hz (LSCF needs both: off the grid,
  every pole moved by a share of a line, 20.033 Hz for 20 Hz).
- Half-power (seed 001): zeta = delta_f / (2 f_n) between the points where the mobility
  falls to its peak over sqrt(2), interpolated linearly between steps.

>>> f = np.arange(20.0, 36.0, 0.05)
>>> w, wn = 2 * np.pi * f, 2 * np.pi * 28.0
>>> fn, z = half_power(f, 1j * w / (wn**2 - w**2 + 2j * 0.01 * wn * w), "mobility")
>>> round(fn, 2), round(z, 4)
(28.0, 0.01)
"""

from __future__ import annotations

import contextlib
import io
import warnings
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.frfset import FrfSet

#: FrfSet quantity -> sdypy-ema frf_form, and the factor (i w)^p turning it into mobility
FORMS = {"acceleration": ("accelerance", -1), "velocity": ("mobility", 0), "displacement": ("receptance", 1)}


def _mobility(f: np.ndarray, h: np.ndarray, quantity: str) -> np.ndarray:
    if quantity not in ("mobility", *FORMS):
        raise InputError(f"must be one of {list(FORMS)}", field="quantity")
    p = 0 if quantity == "mobility" else FORMS[quantity][1]
    return h * (2j * np.pi * f) ** p


def half_power(frequencies_hz: Any, frf: Any, quantity: str = "acceleration") -> tuple[float, float]:
    """(f_n, zeta) by the half-power points of the mobility (seed 001); NaN damping when a
    half-power point lies outside the band."""
    f = np.asarray(frequencies_hz, float)
    order = np.argsort(f)
    f = f[order]
    y = np.abs(_mobility(f, np.asarray(frf, complex)[order], quantity))
    k = int(np.argmax(y))
    fn = float(f[k])
    if 0 < k < f.size - 1:  # parabola through the peak and its neighbours (in f, |Y|^2)
        a, b, c = (y[k - 1: k + 2] ** 2)
        den = a - 2 * b + c
        if den < 0:
            fn = float(f[k] + 0.5 * (a - c) / den * (f[k + 1] - f[k - 1]) / 2)
    half = y[k] / np.sqrt(2)
    lo = hi = np.nan
    for i in range(k, 0, -1):
        if y[i - 1] <= half:
            lo = f[i - 1] + (half - y[i - 1]) / (y[i] - y[i - 1]) * (f[i] - f[i - 1])
            break
    for i in range(k, f.size - 1):
        if y[i + 1] <= half:
            hi = f[i] + (y[i] - half) / (y[i] - y[i + 1]) * (f[i + 1] - f[i])
            break
    return fn, float((hi - lo) / (2 * fn))


def _grid(f: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lines on k df (interpolated when the grid is not uniform or not on multiples of df)."""
    srt = np.argsort(f)
    f, h = f[srt], h[:, srt]
    df = float(np.min(np.diff(f)))
    if df <= 0:
        raise InputError("frequencies must be distinct within a level", field="frequencies_hz")
    k0, k1 = int(np.ceil(f[0] / df - 1e-6)), int(np.floor(f[-1] / df + 1e-6))
    grid = np.arange(k0, k1 + 1) * df
    if grid.size == f.size and np.allclose(grid, f, rtol=0, atol=1e-6 * df):
        return grid, h
    return grid, np.array([np.interp(grid, f, r.real) + 1j * np.interp(grid, f, r.imag) for r in h])


def _from_zero(f: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lines below the band as zeros from 0 Hz (sdypy's own padding, ``np.arange(0,
    f0, df)``, can add a line through rounding and shift every pole by a line's share)."""
    df = float(f[1] - f[0])
    k0 = int(round(f[0] / df))
    return (np.arange(k0 + f.size) * df,
            np.concatenate([np.zeros((h.shape[0], k0), complex), h], axis=1))


def lscf(frequencies_hz: Any, frf: Any, quantity: str = "acceleration", near_hz: float | None = None,
         order: int = 8) -> dict[str, Any]:
    """LSCF pole nearest ``near_hz`` (default: the peak) and LSFD modal constants, by
    sdypy-ema, of FRFs shaped (sensors, n) on one frequency axis."""
    from sdypy import EMA

    f = np.asarray(frequencies_hz, float)
    h = np.atleast_2d(np.asarray(frf, complex))
    if f.ndim != 1 or f.size < 6 or h.shape[1] != f.size:
        raise InputError("LSCF needs at least 6 frequencies and FRFs shaped (sensors, frequencies)",
                         field="frequencies_hz")
    grid, h = _grid(f, h)
    df = float(grid[1] - grid[0])
    if near_hz is None:
        near_hz = float(grid[np.argmax(np.abs(_mobility(grid, h, quantity)).sum(axis=0))])
    form = FORMS[quantity][0]
    # sdypy-ema's numerical warnings (logs of poles, stabilisation ratios) and progress bars stay inside
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        g0, h0 = _from_zero(grid, h)
        m = EMA.Model(frf=h0, freq=g0, lower=grid[0], upper=grid[-1] + 0.5 * df, pol_order_high=order,
                      frf_form=form)
        m.get_poles(method="lscf", show_progress=False)
        picks = _pick(m, near_hz, grid[0], grid[-1])
        if not picks:
            raise InputError(f"LSCF found no physical pole in {grid[0]:g}..{grid[-1]:g} Hz", field="frf")
        fs_ = np.array([p[2] for p in picks])
        best = picks[int(np.argmin(np.abs(fs_ - np.median(fs_))))]
        m.pole_ind = np.array([[best[0], best[1]]])
        _, A = m.get_constants(method="lsfd", f_lower=grid[0], f_upper=grid[-1])
    return {"natural_frequency_hz": float(best[2]), "damping_ratio": float(best[3]),
            "orders_agreeing": len(picks),
            "modal_constants": [[float(a.real), float(a.imag)] for a in np.asarray(A)[:, 0]]}


def _pick(m: Any, near_hz: float, lo: float, hi: float) -> list[tuple[int, int, float, float]]:
    """Per model order (the upper half), the physical pole (0 < zeta < 0.3, in the band)
    nearest ``near_hz``: (order index, pole index, f, zeta)."""
    picks = []
    n = len(m.all_poles)
    for i in range(n // 2, n):
        f, z = np.asarray(m.pole_freq[i]), np.asarray(m.pole_xi[i])
        ok = np.flatnonzero((z > 0) & (z < 0.3) & (f >= lo) & (f <= hi))
        if ok.size:
            k = ok[np.argmin(np.abs(f[ok] - near_hz))]
            pole = -z[k] * 2 * np.pi * f[k] + 1j * 2 * np.pi * f[k] * np.sqrt(1 - z[k] ** 2)
            j = int(np.argmin(np.abs(np.asarray(m.all_poles[i]) - pole)))
            picks.append((i, j, float(f[k]), float(z[k])))
    return picks


def modal_parameters(s: FrfSet, sensor: str | None = None, order: int = 8) -> list[dict[str, Any]]:
    """Per sweep of ``s``: LSCF/LSFD over all sensors and half-power on ``sensor`` (default:
    the sensor with the largest response), natural frequency (Hz) and damping ratio."""
    if sensor is not None and sensor not in s.sensors:
        raise InputError(f"no sensor {sensor!r}; sensors: {list(s.sensors)}", field="sensor")
    out = []
    for (level, direction), idx in s.groups():
        f, h = s.frequencies_hz[idx], s.accelerance()[idx].T if s.quantity == "acceleration" else None
        h = s.response[idx, :, 0].T / s.force[idx] if h is None else h
        j = s.sensors.index(sensor) if sensor else int(np.argmax(np.abs(h).max(axis=1)))
        fn, zeta = half_power(f, h[j], s.quantity)
        out.append({"level_n": level, "level_units": s.level_units, "direction": direction,
                    "steps": int(idx.size),
                    "sensor": s.sensors[j],
                    "lscf": lscf(f, h, s.quantity, near_hz=fn, order=order),
                    "half_power": {"natural_frequency_hz": fn,
                                   "damping_ratio": zeta if np.isfinite(zeta) else None}})
    return out
