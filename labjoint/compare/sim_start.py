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

from labjoint.compare.api import fit_report
from labjoint.compare.kinds.record import RecordMeasurement
from labjoint.errors import InputError
from labjoint.models import Model, Parameters
from labjoint.models.simulate import DEFAULT_SUBSTEPS, simulate

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


def record_output(m: RecordMeasurement) -> tuple[np.ndarray, np.ndarray]:
    """(the measured displacement about its zero, the judged mask) of a record."""
    y = m.data.inputs.u + float(m.metadata.get("displacement_reference_m", 0.0))
    return y, m.data.steady.copy()


def aligned(pred: np.ndarray, y: np.ndarray, judged: np.ndarray) -> np.ndarray:
    """The prediction plus the constant that best matches it to ``y`` on the judged samples."""
    return pred + float(np.mean((y - pred)[judged]))




def _unstable(vals: dict[str, float]) -> str | None:
    """Why a start is not a stable oscillator, or None."""
    m, k = vals.get("inertia.m", 0.0), vals.get("linear_stiffness.k")
    if not m > 0:
        return f"mass inertia.m = {m:.3g} kg <= 0"
    if k is not None and not k > 0:
        return f"stiffness linear_stiffness.k = {k:.3g} N/m <= 0"
    if vals.get("viscous.c", 0.0) < 0:
        return f"damping viscous.c = {vals['viscous.c']:.3g} N s/m < 0"
    return None


def diverges(model: Model, vals: dict[str, float], m: RecordMeasurement, periodic: bool,
              substeps: int) -> str | None:
    """Why the simulation of ``m`` is not usable (not finite, or 1e3 x the measured
    displacement's range), or None."""
    y, judged = record_output(m)
    try:
        pred = simulate(model, vals, m.data.force, m.fs, substeps=substeps, periodic=periodic)
    except InputError as exc:
        return exc.message
    if not np.all(np.isfinite(pred)):
        return "the simulated displacement is not finite (it diverged)"
    if np.ptp(pred[judged]) > 1e3 * max(np.ptp(y[judged]), 1e-300):
        return (f"the simulated displacement spans {np.ptp(pred[judged]):.3g} m, over 1000x "
                f"the measured {np.ptp(y[judged]):.3g} m (it diverged)")
    return None


def _user(start: Parameters, values: dict[str, float] | None,
          bounds: dict[str, tuple[float, float]] | None) -> None:
    """The user's bounds, then start values, on ``start``; refused by name when unknown,
    not finite, or outside the bounds."""
    for k, (lo, hi) in (bounds or {}).items():
        if k not in start:
            raise InputError(f"not a parameter of the model; known: {', '.join(start)}",
                             field=f"bound.{k}")
        q = start[k]
        if not (float(lo) < float(hi)) or float(lo) > q.upper or float(hi) < q.lower:
            raise InputError(f"bounds {lo:g}:{hi:g} are empty or outside the vocabulary's "
                             f"[{q.lower:g}, {q.upper:g}] {q.unit}", field=f"bound.{k}")
        q.lower, q.upper = max(q.lower, float(lo)), min(q.upper, float(hi))
        q.value = float(np.clip(q.value, q.lower, q.upper))
    for k, v in (values or {}).items():
        if k not in start:
            raise InputError(f"not a parameter of the model; known: {', '.join(start)}",
                             field=f"start.{k}")
        q = start[k]
        v = float(v)
        if not (np.isfinite(v) and q.lower <= v <= q.upper):
            raise InputError(f"start {v:g} {q.unit} outside its bounds [{q.lower:g}, "
                             f"{q.upper:g}]", field=f"start.{k}")
        q.value = v


def _sse(model: Model, vals: dict[str, float], recs: list[RecordMeasurement], periodic: bool,
         substeps: int) -> float:
    """Simulation error (sum of squares over the judged samples, each record in units of
    its displacement's standard deviation); inf where a simulation diverges."""
    total = 0.0
    for m in recs:
        y, j = record_output(m)
        try:
            pred = simulate(model, vals, m.data.force, m.fs, substeps=substeps, periodic=periodic)
        except InputError:
            return float("inf")
        with np.errstate(invalid="ignore", over="ignore"):
            r = (y - aligned(pred, y, j))[j] / max(float(np.std(y[j])), 1e-300)
        if not np.all(np.isfinite(r)):
            return float("inf")
        total += float(r @ r)
    return total


def start_values(fit_recs: list[RecordMeasurement], model: Model, seed: int = 0,
                 warm: Parameters | None = None, *, periodic: bool = False,
                 substeps: int = DEFAULT_SUBSTEPS, user: dict[str, float] | None = None,
                 bounds: dict[str, tuple[float, float]] | None = None) -> tuple[Parameters, str]:
    """Start of the search and where it came from (module docstring): the equation-error
    fit of ``model``, or that fit with the values of ``warm`` (a fit of a smaller model)
    where it has them, whichever simulates the records better; the FRF's m, c, k where
    the chosen one is unstable; then the user's values."""
    start = fit_report(fit_recs, model, seed=seed).fit.params_.copy()
    origin = "equation-error fit"
    if warm:
        mixed = start.copy()
        for k, q in warm.items():
            if k in mixed:
                mixed[k].value = float(q.value)
        own = _sse(model, start.valuesdict(), fit_recs, periodic, substeps) \
            if _unstable(start.valuesdict()) is None else float("inf")
        if _sse(model, mixed.valuesdict(), fit_recs, periodic, substeps) <= own:
            start, origin = mixed, "equation-error fit with the smaller model's values"
    vals = start.valuesdict()
    why = _unstable(vals) or diverges(model, vals, fit_recs[0], periodic, substeps)
    if why is not None:
        for k, v in frf_start(fit_recs).items():
            if k in start:
                start[k].value = v
        origin = f"the records' FRF for m, c, k (the equation-error start was unstable: {why})"
    for k, q in start.items():             # log-scaled parameters need a positive start
        if q.value <= 0 and q.lower >= 0 and k != "viscous.c":
            q.value = max(abs(q.upper) * 1e-6 if np.isfinite(q.upper) else 1e-6, 1e-9)
    start["inertia.m"].lower = max(start["inertia.m"].lower, 0.0)
    _user(start, user, bounds)
    if user:
        origin += f"; given: {', '.join(sorted(user))}"
    return start, origin
