"""Backbones from free decays (ringdowns): frequency and damping against amplitude.

A ringdown is the free response after a sine dwell at resonance or a burst, generator
off. Near one mode it is x(t) = a(t) cos(phi(t)) with slowly varying a and phi' = w_d;
the instantaneous decay rate is sigma = -d ln a / dt, the natural frequency
w_n = sqrt(w_d^2 + sigma^2) and the damping ratio zeta = sigma / w_n (exact for a linear
mode, x = A exp(-zeta w_n t) cos(w_d t), w_d = w_n sqrt(1 - zeta^2); for a weakly
nonlinear one they are its amplitude-dependent values, averaging / first-harmonic).

Mode isolation: :mod:`labjoint.signal.ringdown_isolate` (the mode's band-pass; with a
force, also against the force's peaks).

Two estimators, side by side, on the same isolated signal, per window of
``window_cycles`` cycles (non-overlapping, so the windows' uncertainties are
independent):

- ``hilbert``: the analytic signal z = x + i H[x], H a FIR Hilbert transformer of
  2 ``trim_cycles`` cycles (:func:`hilbert_fir`; a local kernel, so the record's ends
  spoil only ``trim_cycles`` cycles at each end, which are cut, where the FFT's
  periodic transform spreads their error over the whole record as 1 / distance);
  smoothing: in each window ln|z| and
  the unwrapped arg z are fitted by straight lines in t (least squares): slope of ln|z|
  = -sigma, slope of the phase = w_d, amplitude = |z| of the line at the window's centre.
- ``peaks``: successive extremes (each refined by a parabola through its 3 samples) and
  zero crossings (linear interpolation); in each window ln|peak| against the peak times
  gives sigma (log decrement delta = sigma T_d), the zero crossings against their index
  give the half period pi / w_d. A damped sine's extremes lie at a constant phase
  arctan(sigma / w_d) before its envelope's, so the amplitude is |peak| / cos(that).

Smoothing bias: a window spans an amplitude change of exp(+-zeta pi N) (N =
``window_cycles``); the fitted slopes are the window's averages, so a backbone curved in
amplitude is biased by about its second derivative times (zeta pi N)^2 / 6 (4 cycles at
zeta = 0.01: a Duffing hardening of 3 % is read 1 % high). Shorter windows lower the bias
and raise the scatter.

Uncertainties: the least-squares standard errors of each window's slopes, with the
residuals' degrees of freedom counted per half cycle (neighbouring samples of the
Hilbert envelope are not independent), propagated to w_n, zeta and the amplitude; the
frequency's and damping's are then raised to at least the window's scatter about its
neighbours' local trend (:mod:`labjoint.signal.ringdown_scatter`: errors smooth within a
window, a beating tone, the force ratio's ripple, leave the least-squares sd too small).
A window counts as above the noise when its envelope exceeds ``snr_min`` x the noise:
the given ``noise_rms``, or else the per-sample noise of the raw record from its second
differences over its last ``TAIL`` fraction (white noise of sd s gives second
differences of sd s sqrt(6); a smooth mode gives almost none at >= 8 samples per cycle):
s = 1.4826 median|x[n+1] - 2 x[n] + x[n-1]| / sqrt(6). That is the broadband noise, an
upper bound of what is left inside the band-pass.

The structure alone (:func:`remove_force`): a ringdown measured with the exciter still
attached (a shaker's armature mass, suspension and the coil's electrical damping act on
the structure through the stinger) is the decay of structure plus exciter. With the
stinger force F(t) recorded and the apparent modal mass m between force and sensor
(from phase resonance, :mod:`labjoint.identify.backbone`), each window's complex ratio
R = F / X of their analytic signals (X the displacement, the response over s^p) is the
exciter's dynamic stiffness, and the mode m (s^2 + 2 zeta w s + w^2) = R at the observed
s = -sigma + i w_d gives the structure's own w and zeta. Their uncertainties are the
uncorrected ones (R's scatter is not propagated). The sensor also moves with the
structure's other modes under F: X = X_mode + C_r F, C_r the residual compliance between
drive and sensor at the mode's frequency (sum over the other mass-normalised modes of
phi_s phi_d / (w_k^2 - w^2), from a model or a modal test); the mode alone sees
R / (1 - C_r R). Leaving it out (C_r = 0) is not small: on a 2-DOF structure whose second
mode is at 2.1x the first, a 0.3 kg armature made the drive-point ringdown 0.003 Hz stiff
and 9 % over-damped (tests/test_ringdown_shaker.py).

Amplitudes are in the signal's own quantity and unit; ``to_displacement`` converts a
velocity (/w) or an acceleration (/w^2, w the window's w_d as recorded, before any force
removal: the motion's own frequency; sign dropped) to a displacement amplitude (stated in
the notes).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import signal as sps

from labjoint.errors import InputError
from labjoint.signal import validate
from labjoint.signal.backbone import Backbone, BackbonePoint
from labjoint.signal.ringdown_isolate import (BAND_ORDER, BAND_OVER_DECAY, FORCE_BAND, PEAK_FRACTION,  # noqa: F401
                                              SETTLE_RTOL, isolate, spectrum_peaks)
from labjoint.signal.ringdown_scatter import honest_sds

METHODS = ("hilbert", "peaks")
#: the record's last fraction whose rms stands for the noise when none is given
TAIL = 0.1
UNIT_BY_QUANTITY = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


def ringdown_backbone(x, fs: float, *, mode_hz: float | None = None, methods=METHODS,
                      quantity: str = "displacement", units: str | None = None,
                      sensor: str = "x", to_displacement: bool = False,
                      window_cycles: int = 4, trim_cycles: float = 2.0,
                      noise_rms: float | None = None, snr_min: float = 10.0,
                      min_windows: int = 3, force=None, modal_mass_kg: float | None = None,
                      residual_compliance_m_per_n: float = 0.0, force_band: str = "octave") -> Backbone:
    """Backbone of one mode from a free decay ``x`` sampled at ``fs`` (module docstring);
    with ``force`` (N, same samples) and ``modal_mass_kg``, of the structure without
    what applies that force (:func:`remove_force`; the other modes' residual compliance
    ``residual_compliance_m_per_n`` between drive and sensor, module docstring)."""
    x = validate.signal(x, "x", min_samples=16)
    if not math.isfinite(residual_compliance_m_per_n):
        raise InputError(f"must be finite, got {residual_compliance_m_per_n!r}",
                         field="residual_compliance_m_per_n")
    if force is not None:
        force = validate.signal(force, "force", min_samples=16)
        validate.same_length(x, force, "x", "force")
        modal_mass_kg = validate.positive(modal_mass_kg, "modal_mass_kg", "kg")
    fs = validate.sample_rate(fs)
    bad = [m for m in methods if m not in METHODS]
    if bad or not methods:
        raise InputError(f"methods are {', '.join(METHODS)}; got {list(methods)!r}", field="methods")
    if quantity not in UNIT_BY_QUANTITY:
        raise InputError(f"quantity is one of {', '.join(UNIT_BY_QUANTITY)}; got {quantity!r}",
                         field="quantity")
    if not (isinstance(window_cycles, int) and window_cycles >= 2):
        raise InputError(f"window_cycles must be an integer >= 2, got {window_cycles!r}",
                         field="window_cycles")
    y, keep, iso = isolate(x, fs, mode_hz, min_cycles=window_cycles * min_windows + 2 * trim_cycles,
                           also=force, force_band=force_band if force is not None else "octave")
    if force_band not in ("octave", "half_octave"):
        raise InputError(f"force_band is octave or half_octave, got {force_band!r}", field="force_band")
    iso = dict(iso)
    f0 = iso["mode_hz"]
    if fs < 8 * f0:
        raise InputError(f"{fs:g} S/s is too slow for a {f0:.4g} Hz mode (need >= 8 samples per "
                         "cycle)", field="fs")
    yF = None if force is None else sps.sosfiltfilt(iso.pop("sos"), force - force.mean())[keep]
    y = y[keep]
    t = np.arange(y.size) / fs
    if noise_rms is None:
        tail = x[-max(16, int(TAIL * x.size)):]
        noise_rms = float(1.4826 * np.median(np.abs(np.diff(tail, 2))) / math.sqrt(6.0))
        noise_from = f"second differences of the record's last {TAIL:.0%}"
    else:
        noise_rms = validate.positive(noise_rms, "noise_rms", "")
        noise_from = "given"
    trim = int(round(trim_cycles * fs / f0))
    power = {"displacement": 0, "velocity": 1, "acceleration": 2}[quantity] if to_displacement else 0
    out_units = "m" if power else (units or UNIT_BY_QUANTITY[quantity])
    notes = [f"mode isolated by a zero-phase band-pass {iso['band_hz'][0]:.4g}-{iso['band_hz'][1]:.4g} Hz "
             f"(order {iso['order']}, forward-backward; {iso['settle_s']:.3g} s of transients cut at each end)",
             f"windows of {window_cycles} cycles; hilbert: {trim_cycles:g} cycles trimmed at each end",
             f"points kept above {snr_min:g} x the noise {noise_rms:.3g} ({noise_from})"]
    if force is not None:
        notes.append(f"the measured force's work removed per window (modal mass {modal_mass_kg:.4g} kg, "
                     f"other modes' residual compliance {residual_compliance_m_per_n:.4g} m/N)")
    if power:
        notes.append(f"{quantity} amplitude converted to displacement by /omega^{power} "
                     "(omega the window's damped frequency)")
    pts: list[BackbonePoint] = []
    counts = {}
    for method in methods:
        rows = (_hilbert_windows if method == "hilbert" else _peak_windows)(y, t, fs, f0, window_cycles, trim)
        above = [r for r in rows if _above_noise(r, noise_rms, snr_min)]
        counts[method] = (len(above), len(rows))
        own: list[BackbonePoint] = []
        for amp, amp_sd, wd, wd_sd, sig, sig_sd, _, t0, t1 in above:
            w_seen = wd                     # the recorded motion's frequency: its amplitude's
            if yF is not None:
                ratio = force_ratio(y, yF, t, fs, f0, trim, t0, t1, complex(-sig, wd),
                                    {"displacement": 0, "velocity": 1, "acceleration": 2}[quantity])
                wd, sig = remove_force(wd, sig, ratio, modal_mass_kg, residual_compliance_m_per_n)
            own.append(_point(amp, amp_sd, wd, wd_sd, sig, sig_sd, power, f"ringdown_{method}", w_seen))
        pts.extend(_with_scatter(own))
    few = {m: c for m, c in counts.items() if c[0] < min_windows}
    if few:
        m, (n_ok, n_all) = next(iter(few.items()))
        raise InputError(
            f"too few cycles above the noise for a backbone ({m}): {n_ok * window_cycles} cycles of "
            f"{n_all * window_cycles} analysed have an envelope > {snr_min:g} x the noise, need "
            f"{min_windows * window_cycles}. What would help: a higher level before switching off, "
            "a more sensitive sensor or range, a longer record, or averaging repeated ringdowns",
            field="x")
    return Backbone(pts, out_units, "displacement" if power else quantity, sensor, tuple(notes))


def force_ratio(y, yF, t, fs, f0, trim, t0, t1, s, power) -> complex:
    """R = F / X over [t0, t1]: the force's analytic signal over the displacement's
    (the response's over s^power, s = -sigma + i w_d), least squares."""
    h = hilbert_fir(fs, f0, max(trim, 2))
    half = h.size // 2
    k = slice(max(int(t0 * fs), half), min(int(t1 * fs) + 1, y.size - half))
    zy = y[k] + 1j * np.convolve(y, h, mode="same")[k]
    zf = yF[k] + 1j * np.convolve(yF, h, mode="same")[k]
    zx = zy / s ** power
    return complex(np.sum(zf * np.conj(zx)) / np.sum(np.abs(zx) ** 2))


def remove_force(wd: float, sigma: float, ratio: complex, mass: float,
                 residual: float = 0.0) -> tuple[float, float]:
    """(w_d, sigma) of the mode without the measured force F = R X acting on it (the
    other modes' share of X, ``residual`` F, taken out first: R -> R / (1 - residual R)):
    m (s^2 + 2 zeta w s + w^2) = R at the observed s = -sigma + i w_d gives
    2 zeta w = 2 sigma + Im R / (m w_d) and w^2 = Re R / m + w_d^2 - sigma^2 + 2 zeta w sigma;
    returned as the (w_d, sigma) of that mode, sigma = zeta w, w_d = sqrt(w^2 - sigma^2)."""
    ratio = ratio / (1.0 - residual * ratio)
    two_zw = 2 * sigma + ratio.imag / (mass * wd)
    w2 = ratio.real / mass + wd * wd - sigma * sigma + two_zw * sigma
    sig = two_zw / 2
    return math.sqrt(max(w2 - sig * sig, 0.0)), sig


def _with_scatter(points: list[BackbonePoint]) -> list[BackbonePoint]:
    """One method's windows (in time order) with frequency and damping sds of at least
    their scatter about their neighbours' local trend (:mod:`labjoint.signal.ringdown_scatter`)."""
    if len(points) < 3:
        return points
    f_sd = honest_sds([p.frequency_hz for p in points], [p.frequency_sd_hz for p in points])
    z_sd = honest_sds([p.damping_ratio for p in points], [p.damping_sd for p in points])
    return [replace(p, frequency_sd_hz=float(a), damping_sd=float(b)) for p, a, b in zip(points, f_sd, z_sd)]


def _point(amp, amp_sd, wd, wd_sd, sig, sig_sd, power, method, w_seen) -> BackbonePoint:
    """A window's point: w_d and sigma the mode's (the force removed), the amplitude
    converted at ``w_seen``, the frequency of the motion recorded (with an exciter
    attached, not the structure's own: a shaker's armature lowers it 2.5 % on the rig)."""
    wn = math.hypot(wd, sig)
    zeta = sig / wn
    # d wn = (wd dwd + sig dsig) / wn ; d zeta = (wd^2 dsig - sig wd dwd) / wn^3
    wn_sd = math.hypot(wd * wd_sd, sig * sig_sd) / wn
    z_sd = math.hypot(wd * wd * sig_sd, sig * wd * wd_sd) / wn ** 3
    a, a_sd = amp / w_seen ** power, math.hypot(amp_sd, power * amp * wd_sd / w_seen) / w_seen ** power
    return BackbonePoint(a, wn / (2 * np.pi), zeta, method, a_sd, wn_sd / (2 * np.pi), z_sd)


def _above_noise(row, noise_rms, snr_min) -> bool:
    return row[0] > snr_min * noise_rms


def _line(t: np.ndarray, y: np.ndarray, dof_per_point: float = 1.0):
    """Least-squares y = a + b (t - tc): (a, b, sd_a, sd_b, residual rms)."""
    tc = t.mean()
    T = t - tc
    b = float(np.dot(T, y - y.mean()) / np.dot(T, T))
    a = float(y.mean())
    r = y - a - b * T
    dof = max(t.size * dof_per_point - 2, 1.0)
    s2 = float(np.dot(r, r)) / t.size * t.size * dof_per_point / dof
    return a, b, math.sqrt(s2 / (t.size * dof_per_point)), math.sqrt(s2 / (np.dot(T, T) * dof_per_point)), \
        math.sqrt(float(np.dot(r, r)) / t.size)


def hilbert_fir(fs: float, f0: float, half: int) -> np.ndarray:
    """Odd-length FIR Hilbert transformer (ideal 2 / (pi n) at odd n, Blackman window),
    ``2 half + 1`` taps, its gain scaled to exactly 1 at ``f0``."""
    n = np.arange(-half, half + 1)
    h = np.where(n % 2 != 0, 2.0 / (np.pi * np.where(n == 0, 1, n)), 0.0) * np.blackman(2 * half + 1)
    return h / abs(np.sum(h * np.exp(-2j * np.pi * f0 * n / fs)))


def _hilbert_windows(y, t, fs, f0, window_cycles, trim):
    trim = max(trim, 2)
    if y.size <= 2 * trim + 2:
        return []
    z = y[trim:y.size - trim] + 1j * np.convolve(y, hilbert_fir(fs, f0, trim), mode="valid")
    tt = t[trim:y.size - trim]
    mag = np.abs(z)
    if np.any(mag <= 0):
        mag = np.maximum(mag, 1e-300)
    lnA, ph = np.log(mag), np.unwrap(np.angle(z))
    n = int(round(window_cycles * fs / f0))
    per_half = 2 * window_cycles / max(n, 1)        # independent values per sample
    rows = []
    for s in range(0, lnA.size - n + 1, n):
        k = slice(s, s + n)
        a, b, _, sb, scat = _line(tt[k], lnA[k], per_half)
        _, wd, _, swd, _ = _line(tt[k], ph[k], per_half)
        amp = math.exp(a)
        # amplitude at the centre; its sd from the scatter of ln|z| about the line
        rows.append((amp, amp * scat / math.sqrt(2 * window_cycles), wd, swd, -b, sb, scat,
                     tt[k][0], tt[k][-1]))
    return rows


def _peak_windows(y, t, fs, f0, window_cycles, trim):
    zc = np.flatnonzero(np.signbit(y[:-1]) != np.signbit(y[1:]))
    if zc.size < 4:
        return []
    tz = t[zc] - y[zc] * (t[zc + 1] - t[zc]) / (y[zc + 1] - y[zc])
    tp, ap = [], []
    for i0, i1 in zip(zc[:-1], zc[1:]):
        seg = np.abs(y[i0 + 1:i1 + 1])
        if seg.size < 3:
            continue
        j = i0 + 1 + int(np.argmax(seg))
        if j <= 0 or j >= y.size - 1:
            continue
        ya, yb, yc = np.abs(y[j - 1:j + 2])
        den = ya - 2 * yb + yc
        d = 0.5 * (ya - yc) / den if den != 0 else 0.0
        tp.append(t[j] + d / fs)
        ap.append(yb - 0.25 * (ya - yc) * d)
    tp, ap = np.array(tp), np.array(ap)
    rows = []
    per = 2 * window_cycles                                  # half cycles (peaks) per window
    half_idx = np.arange(tz.size)
    for s in range(1, min(tp.size, tz.size) - per, per):
        k = slice(s, s + per)
        a, b, _, sb, scat = _line(tp[k], np.log(ap[k]))
        _, half_period, _, shp, _ = _line(half_idx[k].astype(float), tz[k])
        wd = np.pi / half_period
        swd = wd * shp / half_period
        sig = -b
        amp = math.exp(a) / math.cos(math.atan2(sig, wd))
        rows.append((amp, amp * scat / math.sqrt(per), wd, swd, sig, sb, scat, tp[k][0], tp[k][-1]))
    return rows
