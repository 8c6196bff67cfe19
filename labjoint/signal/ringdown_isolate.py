"""Mode isolation for ringdowns (:mod:`labjoint.signal.ringdown`): the spectrum's peaks and
a zero-phase band-pass around the mode asked for.

The spectrum's peaks are found; the mode asked for is
kept by a zero-phase Butterworth band-pass (forward-backward, ``sosfiltfilt``; order 4
between neighbours, 2 for a lone mode, whose transients are shorter) whose
edges lie halfway (geometrically) between it and its neighbours. An exponentially
decaying sine is an eigenfunction of any linear filter, so the band-pass changes
neither sigma nor w_d, only a constant gain (close to 1 inside the band); its start and
end transients are cut off (where they fall below ``SETTLE_RTOL`` of the signal,
:func:`labjoint.signal.filter.settling_samples`).
Two modes are refused as too close when the band would be narrower than 10 x the mode's
decay rate (the filter would then shape the decay) or when its transients would leave
fewer cycles than the analysis needs.

With a force recorded beside the response (the exciter's, for
:func:`labjoint.signal.ringdown.remove_force`), the force's peaks count as neighbours too,
and ``force_band="half_octave"`` gives a lone mode an order-4 band f0 / sqrt 2 .. f0 sqrt 2:
after a sine dwell the next mode's free transient is in the force (drive point, the armature's inertia weights it by
w^2) while barely at the sensor, and its leak through an octave-wide order-2 band beats
in F / X (a 2-DOF generator read 0.002 Hz ripples: tests/test_ringdown_shaker.py).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal as sps

from labjoint.errors import InputError
from labjoint.signal.filter import settling_samples

#: the band-pass must be this many times wider than the mode's decay rate (Hz)
BAND_OVER_DECAY = 10.0
BAND_ORDER = 4
#: the band-pass's transients are cut where they fall below this fraction of the signal
SETTLE_RTOL = 1e-4
#: spectral peaks less prominent than this fraction of the largest (amplitude) are not
#: taken for modes (noise ripples; a weaker mode only widens the band-pass)
PEAK_FRACTION = 0.1
#: ``force_band="half_octave"``: a lone mode's band-pass edges at f0 / this and f0 x this (order 4)
FORCE_BAND = math.sqrt(2.0)


def spectrum_peaks(x: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and amplitudes of the spectral peaks of a record (Hann window,
    zero-padded x4, parabolic interpolation in log amplitude), strongest first."""
    n = x.size
    nfft = 1 << int(math.ceil(math.log2(4 * n)))
    X = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n), nfft))
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    idx, _ = sps.find_peaks(X, height=PEAK_FRACTION * X.max(), prominence=PEAK_FRACTION * X.max())
    idx = idx[(idx > 0) & (idx < X.size - 1)]
    if idx.size == 0:
        return np.array([]), np.array([])
    # a lesser peak within a stronger one's width at a quarter of its height is that
    # mode's noise ripple (two Lorentzian modes are still separated at 4x their bandwidth)
    lo_i, hi_i = sps.peak_widths(X, idx, rel_height=0.75)[2:]
    keep = []
    for j in np.argsort(X[idx])[::-1]:
        if not any(lo_i[k] <= idx[j] <= hi_i[k] for k in keep):
            keep.append(j)
    idx = idx[np.sort(keep)]
    la, lb, lc = (np.log(np.maximum(X[idx + k], 1e-300)) for k in (-1, 0, 1))
    den = la - 2 * lb + lc
    d = np.where(den != 0, 0.5 * (la - lc) / np.where(den != 0, den, 1.0), 0.0)
    fp = f[idx] + d * (f[1] - f[0])
    order = np.argsort(X[idx])[::-1]
    return fp[order], X[idx][order]


def isolate(x: np.ndarray, fs: float, mode_hz: float | None = None, *,
            min_cycles: float = 12.0, also: np.ndarray | None = None,
            force_band: str = "octave") -> tuple[np.ndarray, slice, dict]:
    """The mode nearest ``mode_hz`` (default: the strongest) band-passed, zero-phase;
    the slice of samples free of the filter's transients, and what was done (notes).
    The peaks of ``also`` (a force recorded with ``x``) count as neighbours too: a mode
    hardly seen at the sensor can dominate the force, whose ratio to x the band must keep clean.
    ``force_band``: a lone mode's band, "octave" (order 2, f0 / 2 .. 2 f0) or "half_octave"
    (order 4, f0 / sqrt 2 .. f0 sqrt 2; shuts out the next mode's leak, costs longer transients).

    Refuses (InputError) two modes too close to separate (module docstring)."""
    peaks, _ = spectrum_peaks(x, fs)
    if peaks.size == 0:
        raise InputError("no resonance peak in the record: is it a free decay?", field="x")
    f0 = float(peaks[0] if mode_hz is None else peaks[np.argmin(np.abs(peaks - mode_hz))])
    if mode_hz is not None and abs(f0 - mode_hz) > 0.25 * mode_hz:
        raise InputError(f"no mode near {mode_hz:g} Hz in the record (its peaks: "
                         f"{', '.join(f'{p:.4g}' for p in sorted(peaks))} Hz)", field="mode_hz")
    if also is not None:        # the force's own peak at this mode sits a little off x's
        pa = spectrum_peaks(also, fs)[0]
        peaks = np.concatenate([peaks, pa[np.abs(pa / f0 - 1) > 0.02]])
    below, above = peaks[peaks < f0 * (1 - 1e-6)], peaks[peaks > f0 * (1 + 1e-6)]
    lo = math.sqrt(f0 * below.max()) if below.size else f0 / 2
    hi = math.sqrt(f0 * above.min()) if above.size else min(2 * f0, 0.45 * fs)
    half = min(f0 - lo, hi - f0)
    # the mode's decay rate (Hz) from its envelope, roughly: the band must be much wider
    sigma = _rough_decay(x, fs, f0)
    duration = x.size / fs
    neighbours = [float(p) for p in (below.max() if below.size else None,
                                     above.min() if above.size else None) if p is not None]
    order = BAND_ORDER if neighbours else 2
    if force_band not in ("octave", "half_octave"):
        raise InputError(f"force_band is octave or half_octave, got {force_band!r}", field="force_band")
    if force_band == "half_octave" and not neighbours:
        # with a force, a lone mode's octave-wide order-2 band is not enough: a sine dwell
        # leaves the next mode's free transient in the force (drive point, weighted by the
        # armature's w^2) though barely at the sensor, and its leak beats in F / X
        lo, hi = f0 / FORCE_BAND, min(f0 * FORCE_BAND, 0.45 * fs)
        half, order = min(f0 - lo, hi - f0), BAND_ORDER
    sos = sps.butter(order, [lo, hi], btype="bandpass", fs=fs, output="sos")
    settle = settling_samples(sos, SETTLE_RTOL) / fs
    usable_cycles = (duration - 2 * settle) * f0
    if neighbours and (half < BAND_OVER_DECAY * sigma / (2 * np.pi) or usable_cycles < min_cycles):
        near = min(neighbours, key=lambda p: abs(p - f0))
        need = (min_cycles / f0 + 2 * settle)
        raise InputError(
            f"two modes too close to separate: {f0:.4g} Hz and {near:.4g} Hz; a band-pass between "
            f"them (half-width {half:.3g} Hz) is not 10x wider than the decay rate "
            f"({sigma / (2 * np.pi):.3g} Hz) or its transients leave {max(usable_cycles, 0):.0f} of "
            f"{min_cycles:.0f} cycles needed. What would help: excite one mode alone (a sine dwell at "
            f"{f0:.4g} Hz before switching off, or phase-resonance testing), or a record of at least "
            f"{need:.3g} s", field="x")
    y = sps.sosfiltfilt(sos, x - x.mean())
    cut = int(math.ceil(settle * fs))
    if x.size - 2 * cut < 16:
        raise InputError(f"the record ({duration:.3g} s) is shorter than the band-pass's transients "
                         f"({2 * settle:.3g} s): record a longer decay", field="x")
    keep = slice(cut, x.size - cut)
    notes = {"mode_hz": f0, "band_hz": [lo, hi], "settle_s": settle, "other_modes_hz": neighbours,
             "order": order, "sos": sos}
    return y, keep, notes


def _rough_decay(x: np.ndarray, fs: float, f0: float) -> float:
    """Mean decay rate (1/s) of the record's envelope (first vs last quarter), >= 0."""
    env = np.abs(sps.hilbert(x - x.mean()))
    q = max(1, x.size // 4)
    a, b = np.median(env[:q]), np.median(env[-q:])
    if a <= 0 or b <= 0:
        return 0.0
    return max(0.0, math.log(a / b) / ((x.size - q) / fs))
