"""What excites a record: silence, a steady sine, a swept sine, a multisine, random, a transient.

Found from the signal (the force, the excitation side of a joint record), with the
run's metadata only as a hint that is checked, never trusted blindly:

1. envelope: RMS over windows of two periods of the lowest frequency carrying power;
   the active part is where it exceeds 10 % of its maximum (rest before and after is
   left out). A peak RMS above 2.5x the active part's median (an impact, a decaying
   burst) with no flat stretch (RMS within 15 % of the median) over half the active part
   is a transient; a steady sine after a start-up overshoot keeps its long flat stretch.
2. the steady core: the longest stretch with RMS (averaged over 5 windows) at least half
   that median (ramps out).
3. sine: one spectral line (Hann window, its main lobe) stands 100x above the
   broadband noise and holds >= 80 % of the core's power above that noise, with its
   harmonics >= 95 %; a signal whose dominant line drifts monotonically between the
   core's quarters by more than 1 % (and more than the resolution), each quarter's
   90 %-power band narrower than 0.6 of the whole core's, and that is not periodic
   (step 4), is swept.
4. periodic: the core's autocorrelation has a peak >= 0.8 at a lag with at least two
   periods in the core; the DFT over whole periods then shows the excited lines (power
   20x above the mean noise of the lines between them): a multisine when there are two
   or more that are not all harmonics of one sine, and they hold >= 90 % of the power
   above the noise (else the repetition was approximate: leakage).
5. otherwise random: broadband and not periodic; the band holding 90 % of the power
   is reported.

Pipelines that need a steady sine call :func:`require_sine`, which refuses anything
else with an error naming what was found and the command that handles it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from labjoint.errors import InputError, NotApplicable
from labjoint.signal import validate

KINDS = ("none", "sine", "swept_sine", "multisine", "random", "transient")
#: Longest stretch examined at once (a centred window of longer records).
MAX_SAMPLES = 1 << 21
#: a sweep's quarters each span at most this fraction of the record's 90 %-power band
SWEEP_QUARTER_BAND = 0.6
#: Peak RMS this many times the active part's median RMS: a transient, not steady...
TRANSIENT_PEAK_RATIO = 2.5
#: ...unless the RMS stays within this fraction of the median (flat)...
FLAT_TOLERANCE = 0.15
#: ...over at least this fraction of the active part (a start-up overshoot, then steady).
STEADY_FRACTION = 0.5
#: Commands for records that are not a steady sine (named in refusals).
BROADBAND_COMMANDS = ("`labjoint fit`, `labjoint diagnose` or `labjoint ladder`, which judge "
                      "a model along a record under any excitation")


@dataclass
class Excitation:
    """The excitation found in a record, with the figures that decided it."""

    kind: str
    frequency_hz: float | None = None          # sine: the drive frequency
    period_s: float | None = None              # periodic excitation (multisine)
    lines_hz: list[float] = field(default_factory=list)   # excited lines (multisine)
    band_hz: tuple[float, float] | None = None   # sweep range / band of the power
    active_s: tuple[float, float] | None = None  # first and last active instant
    evidence: str = ""

    def describe(self) -> str:
        """One phrase naming the excitation, e.g. 'a steady sine at 400 Hz'."""
        if self.kind == "sine":
            return f"a steady sine at {self.frequency_hz:.6g} Hz"
        if self.kind == "swept_sine":
            lo, hi = self.band_hz or (float("nan"), float("nan"))
            return f"a swept sine from {lo:.4g} Hz to {hi:.4g} Hz"
        if self.kind == "multisine":
            lines = self.lines_hz
            span = f" from {min(lines):.4g} Hz to {max(lines):.4g} Hz" if lines else ""
            return (f"a multisine with period {self.period_s:.6g} s and {len(lines)} "
                    f"excited lines{span}")
        if self.kind == "random":
            lo, hi = self.band_hz or (float("nan"), float("nan"))
            return f"a random (non-periodic, broadband) excitation, 90 % of its power in {lo:.4g}-{hi:.4g} Hz"
        if self.kind == "transient":
            return "a transient (an impact or decaying burst, no steady part)"
        return "no excitation (the signal is silent)"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "frequency_hz": self.frequency_hz, "period_s": self.period_s,
                "n_lines": len(self.lines_hz), "lines_hz": self.lines_hz[:64],
                "band_hz": list(self.band_hz) if self.band_hz else None,
                "active_s": list(self.active_s) if self.active_s else None,
                "description": self.describe(), "evidence": self.evidence}


def detect_excitation(x: np.ndarray, fs: float, metadata: dict[str, Any] | None = None
                      ) -> Excitation:
    """The excitation of the signal ``x`` sampled at ``fs`` (see the module doc).

    >>> fs = 10_000.0
    >>> t = np.arange(20_000) / fs
    >>> detect_excitation(np.sin(2 * np.pi * 400 * t), fs).describe()
    'a steady sine at 400 Hz'
    """
    fs = validate.sample_rate(fs)
    x = validate.signal(x, "signal", min_samples=16)
    x = x - np.mean(x)
    if not np.any(x):
        return Excitation("none", evidence="the signal is constant")
    spectrum = _spectrum(x, fs)
    win = _envelope_window(x, fs, spectrum)
    n_win = x.size // win
    rms = np.sqrt(np.mean(x[: n_win * win].reshape(n_win, win) ** 2, axis=1))
    peak = float(rms.max())
    active = np.flatnonzero(rms > 0.1 * peak)
    a0, a1 = int(active[0]), int(active[-1]) + 1
    span = (a0 * win / fs, a1 * win / fs)
    level = float(np.median(rms[a0:a1]))
    flat = np.abs(rms[a0:a1] / level - 1.0) <= FLAT_TOLERANCE
    f0, f1 = _longest_run(flat) if flat.any() else (0, 0)
    if peak > TRANSIENT_PEAK_RATIO * level and (f1 - f0) < STEADY_FRACTION * (a1 - a0):
        return Excitation("transient", active_s=span, evidence=(
            f"the peak RMS is {peak / level:.1f}x the median of the active part and the level "
            f"is steady (within {FLAT_TOLERANCE:.0%}) over only {(f1 - f0) / (a1 - a0):.0%} of "
            "it: the energy comes in a burst that decays, not a steady excitation"))
    # the envelope averaged over 5 windows: a multisine's RMS dips between its bursts
    # (crest factor) must not cut the steady core; a ramp changes slowly and still shows
    smooth = np.convolve(rms[a0:a1], np.ones(5) / 5, mode="same") if a1 - a0 >= 5 else rms[a0:a1]
    strong = smooth >= 0.5 * level
    c0, c1 = _longest_run(strong)
    # a core reaching the last whole window takes the partial window after it too
    core = x[(a0 + c0) * win:(a0 + c1) * win if a0 + c1 < n_win else x.size]
    if core.size > MAX_SAMPLES:
        mid = core.size // 2
        core = core[mid - MAX_SAMPLES // 2: mid + MAX_SAMPLES // 2]
    # the core is often the whole signal: its spectrum is then the one already taken
    found = _sine_or_sweep(core, fs, spectrum if core.size == x.size else None)
    if found is None or found.kind == "swept_sine":   # a periodic record is never a sweep
        found = _periodic(core, fs) or found or _random(core, fs)
    found.active_s = span
    hint = (metadata or {}).get("frequency_hz")
    if hint and found.kind == "sine" and abs(found.frequency_hz - float(hint)) > 0.02 * float(hint):
        found.evidence += (f"; the metadata says {float(hint):g} Hz but the signal's line "
                           f"is at {found.frequency_hz:.6g} Hz")
    return found


def require_sine(found: Excitation, pipeline: str, source: str = "the record") -> None:
    """Refuse anything but a steady sine, naming what was found and what handles it."""
    if found.kind == "sine":
        return
    handler = ("record the excitation first" if found.kind == "none" else
               f"use {BROADBAND_COMMANDS}" if found.kind in ("multisine", "random", "swept_sine")
               else "it has no steady cycles to analyse")
    raise NotApplicable(f"{source} holds {found.describe()}, not a steady sine, and {pipeline} "
                     f"needs a steady sine ({found.evidence}): {handler}", field="excitation")


def _envelope_window(x: np.ndarray, fs: float,
                     spectrum: tuple[np.ndarray, np.ndarray] | None = None) -> int:
    """RMS window: two periods of the lowest frequency carrying power (5 % quantile)."""
    freqs, p = _spectrum(x, fs) if spectrum is None else spectrum
    c = np.cumsum(p) / p.sum()
    f_low = max(float(freqs[int(np.searchsorted(c, 0.05))]), freqs[1])
    return int(np.clip(round(2.0 * fs / f_low), 16, max(16, x.size // 8)))


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """[start, stop) of the longest run of True in ``mask`` (at least one True)."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    starts, stops = edges[::2], edges[1::2]
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k])


@lru_cache(maxsize=8)
def _hann(n: int) -> np.ndarray:
    w = np.hanning(n)
    w.flags.writeable = False
    return w


def _spectrum(x: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    p = np.abs(np.fft.rfft(x * _hann(x.size))) ** 2
    p[0] = 0.0
    return np.fft.rfftfreq(x.size, 1.0 / fs), p


def _peak_hz(freqs: np.ndarray, p: np.ndarray) -> float:
    """Dominant line, refined by a parabola through the log power (Hann window)."""
    k = int(np.argmax(p))
    if 0 < k < p.size - 1 and p[k - 1] > 0 and p[k + 1] > 0:
        a, b, c = np.log(p[k - 1]), np.log(p[k]), np.log(p[k + 1])
        den = a - 2 * b + c
        off = 0.5 * (a - c) / den if den != 0 else 0.0
        return float(freqs[k] + off * (freqs[1] - freqs[0]))
    return float(freqs[k])


def _line_power(freqs: np.ndarray, p: np.ndarray, f: float, lobe: int = 3) -> float:
    df = freqs[1] - freqs[0]
    k = int(round(f / df))
    return float(p[max(k - lobe, 1): k + lobe + 1].sum())


def _sine_or_sweep(core: np.ndarray, fs: float,
                   spectrum: tuple[np.ndarray, np.ndarray] | None = None) -> Excitation | None:
    freqs, p = _spectrum(core, fs) if spectrum is None else spectrum
    # broadband noise is not part of the excitation: the median bin (chi^2, 2 dof, of a
    # Hann-windowed spectrum) / ln 2 is its mean level per bin
    noise_bin = float(np.median(p[1:])) / np.log(2.0)
    total = max(float(p.sum()) - noise_bin * (p.size - 1), 1e-300)
    f0 = _peak_hz(freqs, p)
    line = _line_power(freqs, p, f0)
    fund = min(line / total, 1.0)
    harm = sum(_line_power(freqs, p, h * f0) for h in range(2, 11) if h * f0 < fs / 2) / total
    if line < 100.0 * 7 * noise_bin:                  # not a line standing out of the noise
        fund = 0.0
    quarters = [q for q in np.array_split(core, 4) if q.size >= 64]
    fq = [_peak_hz(*_spectrum(q, fs)) for q in quarters]
    res = 0.5 * 4.0 * fs / quarters[0].size if quarters else np.inf  # half a quarter's bin
    d = np.diff(fq)
    monotonic = len(fq) >= 3 and (np.all(d > 0) or np.all(d < 0))
    spread = max(fq) - min(fq) if fq else 0.0
    if monotonic and spread > max(0.01 * np.median(fq), res) and _narrow(core, quarters, fs):
        return Excitation("swept_sine", band_hz=(float(fq[0]), float(fq[-1])), evidence=(
            f"the dominant line moves from {fq[0]:.4g} Hz to {fq[-1]:.4g} Hz across the record"))
    if fund >= 0.8 and fund + harm >= 0.95:
        return Excitation("sine", frequency_hz=f0, evidence=(
            f"one line at {f0:.6g} Hz holds {fund:.1%} of the power, with its harmonics "
            f"{fund + harm:.1%}"))
    return None


def _narrow(core: np.ndarray, quarters: list[np.ndarray], fs: float) -> bool:
    """A sweep's quarters each hold a narrow part of its band; a broadband signal's
    dominant line wanders by chance, but each quarter spans the whole band."""
    core_w = np.subtract(*power_band(core, fs)[::-1])
    q_res = fs / quarters[0].size            # a quarter's bin: bands below ~8 unresolved
    q_w = float(np.median([np.subtract(*power_band(q, fs)[::-1]) for q in quarters]))
    return bool(core_w <= 8 * q_res or q_w < SWEEP_QUARTER_BAND * core_w)


def _periodic(core: np.ndarray, fs: float) -> Excitation | None:
    n = core.size
    spec = np.fft.rfft(core, 2 * n)
    ac = np.fft.irfft(np.abs(spec) ** 2)[:n]
    ac = ac / ac[0]
    # unbiased: the overlap shrinks with the lag; look for lags leaving >= 2 periods
    lags = np.arange(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        acu = ac * n / (n - lags)
    lo = max(8, int(0.002 * fs))
    hi = n // 2
    if hi <= lo:
        return None
    seg = acu[lo:hi]
    # the first lag where the correlation comes back near 1 is the period
    cand = np.flatnonzero(seg >= 0.8)
    if cand.size == 0:
        return None
    k = lo + int(cand[0])
    stop = min(k + max(2, k // 50), hi)
    lag = k + int(np.argmax(acu[k:stop]))
    m = n // lag
    whole = core[: m * lag]
    p = np.abs(np.fft.rfft(whole)) ** 2
    bins = np.arange(p.size)
    on = bins[(bins % m == 0) & (bins > 0)]
    off = bins[(bins % m != 0) & (bins > 0)]
    floor = float(np.median(p[off])) if off.size else 0.0
    # noise bins are chi^2 with 2 dof (mean = median / ln 2): 20x the mean is exceeded by
    # noise with probability e^-20, so no line is invented among 1e6 bins
    level = max(20.0 * floor / np.log(2.0), 1e-10 * float(p[on].max()))
    excited = on[p[on] > level]
    if excited.size < 2:
        return None
    signal_power = float(p[1:].sum()) - floor / np.log(2.0) * (p.size - 1 - excited.size)
    if float(p[excited].sum()) < 0.9 * signal_power:   # leakage: not periodic at this lag
        return None
    lines = (excited / (m * lag / fs)).tolist()
    base = lines[0]
    if all(abs(f / base - round(f / base)) < 1e-6 for f in lines) and \
            p[excited[0]] > 0.8 * p[excited].sum():
        return None                                    # a distorted sine, not a multisine
    return Excitation("multisine", period_s=lag / fs, lines_hz=[float(f) for f in lines],
                      evidence=(f"the record repeats every {lag} samples "
                                f"(autocorrelation {acu[lag]:.3f}); {excited.size} lines "
                                f"stand 100x above the lines between them over {m} periods"))


def power_band(x: np.ndarray, fs: float) -> tuple[float, float]:
    """The band holding the middle 90 % of the power of ``x`` (Hz)."""
    freqs, p = _spectrum(x, fs)
    c = np.cumsum(p) / max(float(p.sum()), 1e-300)
    return (float(freqs[int(np.searchsorted(c, 0.05))]),
            float(freqs[min(int(np.searchsorted(c, 0.95)), freqs.size - 1)]))


def _random(core: np.ndarray, fs: float) -> Excitation:
    lo, hi = power_band(core, fs)
    return Excitation("random", band_hz=(lo, hi), evidence=(
        "no single line, no drift of one line, and no repetition: broadband"))


#: Samples read from the middle of a long record, and from its quarters, by
#: :func:`detect_streamed` (a record streamed from a file is never read whole for this).
PROBE_SAMPLES = 1 << 18
QUARTER_SAMPLES = 1 << 16


def detect_streamed(read: Any, n_samples: int, fs: float,
                    metadata: dict[str, Any] | None = None) -> Excitation:
    """:func:`detect_excitation` of a record read through ``read(start, stop)``.

    Records up to four probes long are read whole; longer ones through a probe in the
    middle, and, when that is a sine, two shorter ones at a quarter and three quarters
    of the record: a line that moved by more than 1 % between them is a slow sweep.
    """
    if n_samples <= 4 * PROBE_SAMPLES:
        return detect_excitation(read(0, n_samples), fs, metadata)
    mid = n_samples // 2
    found = detect_excitation(read(mid - PROBE_SAMPLES // 2, mid + PROBE_SAMPLES // 2), fs,
                              metadata)
    if found.kind != "sine":
        return found
    lines = []
    for at in (n_samples // 4, 3 * n_samples // 4):
        part = read(at - QUARTER_SAMPLES // 2, at + QUARTER_SAMPLES // 2)
        lines.append(_peak_hz(*_spectrum(part - part.mean(), fs)))
    if abs(lines[1] - lines[0]) > 0.01 * found.frequency_hz:
        return Excitation("swept_sine", band_hz=(float(lines[0]), float(lines[1])), evidence=(
            f"the line is at {lines[0]:.4g} Hz a quarter into the record, "
            f"{found.frequency_hz:.4g} Hz in the middle and {lines[1]:.4g} Hz at three quarters"))
    return found
