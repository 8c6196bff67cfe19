"""A stable start for the simulation-error fit, from the records' own FRF.

The equation-error fit (the force balance along the measured displacement) can come out
with a mass or stiffness <= 0 (a record whose resonance it barely sees, a band where the
derivatives are noise): a start the forward simulation cannot follow (it diverges, and
an unstable start leaves least squares nothing to descend). The records' FRF gives a
positive one: the receptance H(f) = S_Fu / S_FF (Welch averages over the judged
samples), restricted to the excited band (force power above ``BAND_FLOOR`` of its
largest line), and the single-degree-of-freedom law 1 / H = k - m w^2 + i c w fitted by
linear least squares (real part: k and m; imaginary part: c). Where that is still not
positive (no resonance in the band, or one dominated by another mode), the resonance is
read from the peak of |H| (w_n), k from |1 / H| at the lowest excited frequency and m =
k / w_n^2, c from the peak's height: c = 1 / (w_n |H(w_n)|).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.signal import csd, welch

from labjoint.compare.kinds.record import RecordMeasurement
from labjoint.errors import InputError

BAND_FLOOR = 1e-3


def receptance(recs: Sequence[RecordMeasurement]) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies in Hz, H = displacement / force) over the excited band, pooled over
    records of one sample rate (cross and auto spectra summed)."""
    fs = recs[0].fs
    sfu = sff = f = None
    for m in recs:
        j = np.flatnonzero(m.data.steady)
        F = m.data.force[j[0]:j[-1] + 1]
        u = m.data.inputs.u[j[0]:j[-1] + 1]
        n = F.size
        per = int(round(m.excitation.period_s * fs)) if m.excitation.period_s else 0
        nseg = per if 64 <= per <= n else min(n, max(256, n // 8))
        f_i, s_fu = csd(F - F.mean(), u - u.mean(), fs=fs, nperseg=nseg)
        _, s_ff = welch(F - F.mean(), fs=fs, nperseg=nseg)
        if f is None or f_i.size != f.size:
            f, sfu, sff = f_i, s_fu, s_ff
        else:
            sfu, sff = sfu + s_fu, sff + s_ff
    assert f is not None and sfu is not None and sff is not None
    band = (sff > BAND_FLOOR * sff.max()) & (f > 0)
    if band.sum() < 2:
        raise InputError("the force excites fewer than 2 frequency lines: no FRF to start "
                         "the simulation from; give --start values", field="start")
    return f[band], (sfu / sff)[band]


def frf_start(recs: Sequence[RecordMeasurement]) -> dict[str, float]:
    """Positive m, c, k of the records' SDOF receptance (module docstring)."""
    f, H = receptance(recs)
    w = 2 * np.pi * f
    inv = 1.0 / H
    A = np.column_stack([np.ones_like(w), -w * w])
    k, m = np.linalg.lstsq(A, inv.real, rcond=None)[0]
    c = float(np.linalg.lstsq(w[:, None], inv.imag, rcond=None)[0][0])
    if not (k > 0 and m > 0):
        i = int(np.argmax(np.abs(H)))
        wn = w[i]
        k = float(abs(inv[np.argmin(w)]))
        m = k / wn ** 2
        c = 1.0 / (wn * abs(H[i]))
    return {"inertia.m": float(m), "linear_stiffness.k": float(k), "viscous.c": float(max(c, 0.0))}
