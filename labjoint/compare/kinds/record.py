"""The ``record`` kind: a record under any excitation, judged sample by sample along its history.

Multisine, swept sine, random, transient or a sine: nothing assumes cycles. The model
runs along the whole measured displacement history from the record's first sample,
every hysteretic state with it (:mod:`labjoint.models.inputs`), and is judged on the
force, sample by sample (NRMSE, design.md), from the end of a warm-up on.

Preparation (:func:`prepare_record`):

- excitation: :func:`labjoint.signal.excitation.detect_excitation` on the run's excitation
  signal (the reference force if recorded, else the joint force); a
  silent record is refused. Periodic (a sine, a multisine): its period; otherwise not.
- warm-up: every model state starts relaxed at the first sample, which the joint was not
  unless the record starts at rest. A Masing-type hysteretic state is wiped once the
  motion has reached both of its extremes, so judging starts where the displacement has
  first reached both its 1st and 99th percentiles (``warmup="auto"``; a number of
  seconds or 0 instead, when the record is known to start at rest). A record that
  visibly begins at rest (a quiet lead-in of displacement and force before the
  excitation, :func:`starts_at_rest`) is judged from the excitation's start under
  "auto": the joint's states start where the model's do (a random record's extremes
  come late, and waiting for them had refused records of seconds).
- units (the paired significance test and the over-time map work on them): whole
  periods of a periodic excitation from the judging start; otherwise blocks of
  max(4 / lowest excited frequency, 1/64 of the judged span), at least ``MIN_UNITS``.
- displacement zero: the mean of the quiet lead-in when the record starts at rest (the
  excitation starts ``REST_SAMPLES`` or more into the record and the displacement moves
  by less than ``REST_FRACTION`` of its judged range before it), else the mean over the judged units (whole periods or blocks: where a joint that is
  symmetric about its rest position sits on average under a force of zero mean).
- derivatives: the band-limited spectral ones of :mod:`labjoint.models.inputs`, with
  periodic continuation at the edges only for periodic excitation. Band: for broadband
  excitation (multisine, sweep, random), ``EXCITED_FACTOR`` x the frequency below which
  ``EXCITED_POWER`` of the excitation's power lies (periodogram of the excited span;
  the data's own band, not the detector's lines) (the judged force balance in the excited band: a mass or damper fed
  the displacement noise differentiated up to kHz had a residual of the noise times
  m w^2 and estimates biased towards zero, errors in the variables; an inertia +
  viscous + linear record with 0.5 % noise fitted m ~ 0 and k < 0 at 99.5 % NRMSE, and
  a channel delay looked like the fix), with a roll-off of order ``EXCITED_ORDER`` (it
  passes 99.9 % of the top excited line's velocity and stops the noise above the band). A sine, or a band unknown: max(3 kHz, 8 x the
  highest excited frequency). Capped at 0.4 fs.

Noise floor (stated): periodic excitation with at least ``MIN_WINDOW_CYCLES`` judged
periods: the period-to-period scatter of the sine kind (:mod:`labjoint.compare.noise`,
windows, trend, excess-scatter windows left out); with 2 to 4 periods: the difference of
the quietest pair of consecutive periods (a decaying start-up response is left out).
Non-periodic, or one judged period (the validation part of a short periodic record): the
difference method (the robust variance of the d-th difference,
from its median absolute deviation, divided by C(2d, d), the smallest over d = 1..6;
consistent for Gaussian white noise on a signal smooth on the sample scale, whose
stick-slip kinks are sparse spikes the median ignores; an upper bound where the signal
itself holds power near Nyquist). Force-equivalent noise sigma_F^2 + k^2 sigma_u^2 as for sines,
k the least-squares stiffness of F on (u, v, 1), plus the displacement noise passed through
the derivatives into the damping and inertia forces: c^2 sigma_u^2 G_v + m^2 sigma_u^2 G_a,
(k, c, m) the least squares of F on (u, v, a, 1), G_v and G_a the white-noise gains of the
band-limited first and second derivatives (the mean of |H(f)|^2 over 0..fs/2).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from labjoint.compare.kinds.record_maps import RecordKind
from labjoint.compare.measurement import RunNoise
from labjoint.compare.noise import (MIN_WINDOW_CYCLES, difference_variance, interpolation_gain,
                                   quietest_variance,
                                    scatter_variance)
from labjoint.errors import InputError
from labjoint.models import RunData
from labjoint.models.inputs import BUTTER_ORDER, DEFAULT_BAND_HZ, ModelInputs, derivatives
from labjoint.signal.cycles import cycles as resample_cycles
from labjoint.signal.excitation import Excitation, detect_excitation
from labjoint.storage import Run, read_any

MIN_UNITS = 4
EXCITED_FACTOR = 1.15
EXCITED_POWER = 0.999
EXCITED_ORDER = 24
BLOCK_PERIODS = 4.0
MAX_BLOCKS = 64
REST_FRACTION = 0.02
REST_SAMPLES = 8
REST_STD = 0.15
EXTREME_PCT = 1.0
METHOD = ("periodic excitation: period-to-period scatter of the judged periods; otherwise "
          "the difference method (robust variance of the d-th difference / C(2d, d), smallest "
          "over d = 1..6); force noise plus displacement noise times the least-squares stiffness")


@dataclass(frozen=True, eq=False)
class RecordMeasurement:
    """A record under any excitation, prepared (module docstring). ``spans``: the units'
    (start, stop) samples; ``bounds``: their fractional starts and the last stop (periodic
    excitation), else None."""

    kind: ClassVar[str] = "record"
    noise_method: ClassVar[str] = METHOD
    name: str
    data: RunData
    excitation: Excitation
    spans: np.ndarray
    bounds: np.ndarray | None
    path: str | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def fs(self) -> float:
        return float(self.data.inputs.fs)

    @property
    def judged(self) -> slice:
        return slice(int(self.spans[0, 0]), int(self.spans[-1, 1]))

    def units(self) -> np.ndarray:
        return self.spans

    def axes(self) -> dict[str, Any]:
        u = self.data.inputs.u[self.judged]
        f = self.data.force[self.judged]
        return {"excitation": self.excitation.kind,
                "displacement_rms_m": float(np.std(u)), "force_rms_n": float(np.std(f))}

    def figures(self, model_force: np.ndarray) -> dict[str, float]:
        """Energy dissipated over the judged samples (J: the sum of F v / fs) and the
        least-squares stiffness of F on (u, v, 1) (N/m), measured and model."""
        j = self.judged
        u, v = self.data.inputs.u[j], self.data.inputs.v[j]
        A = np.column_stack([u, v, np.ones_like(u)])
        out = {}
        for side, f in (("measured", self.data.force[j]), ("model", model_force[j])):
            out[f"energy_loss_{side}_j"] = float(f @ v) / self.fs
            out[f"stiffness_{side}_n_per_m"] = float(np.linalg.lstsq(A, f, rcond=None)[0][0])
        return out

    def noise(self) -> RunNoise:
        """Noise by the stated method (module docstring)."""
        j = self.judged
        F, u = self.data.force, self.data.inputs.u
        n_units = int(self.spans.shape[0])
        if self.bounds is not None and n_units >= MIN_WINDOW_CYCLES:
            var_f, n_used, n_win = scatter_variance(F, [self.bounds])
            var_u = quietest_variance(u, [self.bounds])
        elif self.bounds is not None and n_units >= 2:
            var_f, var_u, n_used, n_win = (period_scatter(F, self.bounds),
                                           period_scatter(u, self.bounds), n_units, 1)
        else:
            var_f, var_u, n_used, n_win = difference_variance(F[j]), difference_variance(u[j]), n_units, 0
        inp = self.data.inputs
        A = np.column_stack([u[j], inp.v[j], inp.a[j], np.ones(j.stop - j.start)])
        k, c, m = (float(x) for x in np.linalg.lstsq(A, F[j], rcond=None)[0][:3])
        band = float(self.metadata.get("derivative_band_hz", DEFAULT_BAND_HZ))
        g_v, g_a = derivative_gains(self.fs, band,
                                    int(self.metadata.get("derivative_order", BUTTER_ORDER)))
        gain = k * k + c * c * g_v + m * m * g_a
        var_eq = var_f + (gain * var_u if np.isfinite(var_u) else 0.0)
        rms = float(np.sqrt(np.mean(F[j] ** 2)))
        eq = float(np.sqrt(var_eq)) if np.isfinite(var_eq) else float("nan")
        return RunNoise(self.name, float(np.sqrt(var_f)), float(np.sqrt(var_u)), eq,
                        eq / rms if rms > 0 else float("nan"), n_used, n_win)

    def renamed(self, name: str) -> RecordMeasurement:
        return replace(self, name=name, data=self.data.renamed(name))

    def part(self, first: int, stop: int, label: str) -> RecordMeasurement:
        """The same record judged on its units ``first:stop`` only, named ``name[label]``
        (the model still runs over the whole history)."""
        spans = self.spans[first:stop]
        keep = np.zeros(len(self.data.force), bool)
        keep[int(spans[0, 0]):int(spans[-1, 1])] = True
        bounds = None if self.bounds is None else self.bounds[first:stop + 1]
        name = f"{self.name}[{label}]"
        return replace(self, name=name, spans=spans, bounds=bounds,
                       data=self.data.renamed(name, keep))


def period_scatter(x: np.ndarray, bounds: np.ndarray) -> float:
    """White-noise variance from 2 or more periods: half the mean square difference of
    two consecutive periods, the quietest pair (each period resampled at the nearest
    integer number of samples per period). A structure's free response decaying from the
    start differs most between the first periods; the quietest pair is the most settled
    (the minimum of a few estimates with M degrees of freedom each is low by ~sqrt(2/M)).
    With a whole number of samples per period, the difference method along each pair's
    difference is taken too, where it is lower."""
    m = max(8, int(round(float(np.mean(np.diff(bounds))))))
    c = resample_cycles(np.asarray(x, dtype=float), bounds, m, check=False)
    d = np.diff(c, axis=0)
    gain = interpolation_gain(bounds, m)
    best = float(np.min(np.mean(d * d, axis=1))) / 2.0 / gain
    if abs(gain - 1.0) < 1e-9:
        # whole samples per period: the difference of two periods is the noise plus what
        # is left of the free response, slow beside the sampling; the difference method
        # along it leaves that out (the ringing read 400x a 1e-7 m noise)
        best = min(best, min(difference_variance(row) for row in d) / 2.0)
    return best


def starts_at_rest(u: np.ndarray, F: np.ndarray, a0: int, a1: int) -> bool:
    """Whether the record begins at rest: a lead-in of ``REST_SAMPLES`` or more before the
    excitation over which displacement and force each scatter by less than
    ``REST_STD`` of their standard deviation while excited (a standard deviation, not a
    range: sensor noise alone spans several of them). The joint sat still there, its
    states where the model starts them (relaxed at the first sample), so no warm-up is
    needed."""
    if a0 < REST_SAMPLES or a1 <= a0:
        return False
    return all(np.std(x[:a0]) < REST_STD * np.std(x[a0:a1]) for x in (u, F))


def _warmup_start(u: np.ndarray, a0: int, a1: int, warmup: str | float, fs: float) -> int:
    if warmup == "auto":
        lo, hi = np.percentile(u[a0:a1], [EXTREME_PCT, 100.0 - EXTREME_PCT])
        seg = u[a0:a1]
        i_lo = int(np.argmax(seg <= lo))
        i_hi = int(np.argmax(seg >= hi))
        return a0 + max(i_lo, i_hi)
    try:
        w = float(warmup)
    except (TypeError, ValueError):
        raise InputError(f"must be 'auto' or a number of seconds >= 0, got {warmup!r}",
                         field="warmup") from None
    if not (np.isfinite(w) and w >= 0):
        raise InputError(f"must be 'auto' or a number of seconds >= 0, got {warmup!r}",
                         field="warmup")
    return a0 + int(round(w * fs))


def _band(exc: Excitation) -> tuple[float | None, float | None]:
    """(lowest, highest) excited frequency (Hz), None where unknown."""
    if exc.kind == "sine":
        return exc.frequency_hz, exc.frequency_hz
    if exc.lines_hz:
        return min(exc.lines_hz), max(exc.lines_hz)
    if exc.band_hz:       # a sweep's (start, end): downward sweeps start at the top
        return min(exc.band_hz), max(exc.band_hz)
    return None, None


def power_top(x: np.ndarray, fs: float, share: float = EXCITED_POWER) -> float | None:
    """The frequency (Hz) below which ``share`` of the power of ``x`` (mean removed) lies:
    the periodogram of the whole span (every sample counts alike: Welch's segments drop a
    sweep's last part, a taper its ends); None for a record too short or silent."""
    x = np.asarray(x, dtype=float)
    if x.size < 64:
        return None
    p = np.abs(np.fft.rfft(x - x.mean())) ** 2
    f = np.fft.rfftfreq(x.size, 1.0 / fs)
    c = np.cumsum(p)
    if not c[-1] > 0:
        return None
    return float(f[min(int(np.searchsorted(c, share * c[-1])), f.size - 1)])


def derivative_band(exc: Excitation, f_hi: float | None, top: float | None = None
                    ) -> tuple[float, int]:
    """The derivatives' band (Hz) and roll-off order for an excitation (module docstring);
    ``top``: the excitation's :func:`power_top`."""
    if exc.kind != "sine" and top:
        return EXCITED_FACTOR * top, EXCITED_ORDER
    return max(DEFAULT_BAND_HZ, 8.0 * (f_hi or 0.0)), BUTTER_ORDER


def derivative_gains(fs: float, band: float, order: int = BUTTER_ORDER) -> tuple[float, float]:
    """White-noise variance gains (G_v in 1/s^2, G_a in 1/s^4) of the band-limited
    derivatives of :func:`labjoint.models.inputs.derivatives`: the mean of |H(f)|^2 over
    0..fs/2 with H = (j 2 pi f)^d / (1 + (f / band)^(2 order))."""
    f = np.linspace(0.0, 0.5 * fs, 8193)
    h2 = 1.0 / (1.0 + (f / band) ** (2 * order)) ** 2
    w2 = (2 * np.pi * f) ** 2
    return float(np.mean(w2 * h2)), float(np.mean(w2 * w2 * h2))


def prepare_record(run: Run | str | Path, *, band_hz: float | None = None,
                   warmup: str | float = "auto",
                   excitation: Excitation | None = None) -> RecordMeasurement:
    """Prepare a record under any excitation (module docstring); ``excitation``: what
    :func:`~labjoint.signal.excitation.detect_excitation` already found in it."""
    if isinstance(run, (str, Path)):
        run = read_any(run)
    if not isinstance(run, Run):
        raise InputError(f"expected a run file path or a Run, got {type(run).__name__}", field="runs")
    where = run.path or run.name
    fs = float(run.sample_rate_hz)
    F = np.asarray(run.force, dtype=float)
    u_raw = np.asarray(run.displacement, dtype=float)
    n = F.size
    exc = excitation or detect_excitation(run.excitation, fs, dict(run.metadata))
    if exc.kind == "none":
        raise InputError(f"run '{run.name}': the force is silent, nothing excites the joint",
                         file=where, field="force")
    span = exc.active_s or (0.0, n / fs)
    a0, a1 = max(0, int(span[0] * fs)), min(n, int(np.ceil(span[1] * fs)))
    at_rest = starts_at_rest(u_raw, F, a0, a1)
    j0 = a0 if warmup == "auto" and at_rest else _warmup_start(u_raw, a0, a1, warmup, fs)
    periodic = exc.kind in ("sine", "multisine")
    per = (fs / exc.frequency_hz if exc.kind == "sine" else
           exc.period_s * fs if exc.kind == "multisine" and exc.period_s else None)
    if per is not None and (a1 - 3 - max(j0, 1)) >= 2 * per:
        start = float(max(j0, 1))
        k = int(np.floor((a1 - 3 - start) / per))
        bounds = start + per * np.arange(k + 1)
        edges = np.ceil(bounds).astype(np.int64)
    else:
        periodic, bounds = False, None
        f_lo = _band(exc)[0] or 1.0
        length = max(int(np.ceil(BLOCK_PERIODS * fs / f_lo)), (a1 - j0) // MAX_BLOCKS, 8)
        k = (a1 - j0) // length
        edges = j0 + length * np.arange(k + 1, dtype=np.int64)
    if edges.size - 1 < (2 if periodic else MIN_UNITS):
        need = "2 periods" if per is not None else f"{MIN_UNITS} blocks of {BLOCK_PERIODS:g} periods of its lowest frequency"
        raise InputError(f"run '{run.name}': after the warm-up (from {j0 / fs:.4g} s) too little "
                         f"of the record is left to judge; need {need}", file=where, field="steady")
    spans = np.column_stack([edges[:-1], edges[1:]])
    keep = np.zeros(n, bool)
    keep[int(spans[0, 0]):int(spans[-1, 1])] = True
    head = u_raw[:a0]
    if at_rest or (a0 >= REST_SAMPLES and np.ptp(head) < REST_FRACTION * np.ptp(u_raw[keep])):
        ref = float(np.mean(head))
    else:
        ref = float(np.mean(u_raw[keep]))
    u = u_raw - ref
    f_hi = _band(exc)[1]
    band, order = derivative_band(exc, f_hi, power_top(np.asarray(run.excitation, float)[a0:a1], fs))
    band = min(band_hz if band_hz is not None else band, 0.4 * fs)
    v, a = derivatives(u, fs, band, fs / per if periodic and per else None, periodic=periodic,
                       order=order)
    ups = np.count_nonzero((u[keep][:-1] < 0) & (u[keep][1:] >= 0))
    f_char = ups * fs / keep.sum() if ups else (f_hi or fs / keep.sum())
    md = dict(run.metadata)
    md.update(displacement_reference_m=ref, excitation=exc.to_dict(), judged_from_s=spans[0, 0] / fs,
              derivative_band_hz=band, derivative_order=order)
    inputs = ModelInputs(u, v, a, fs, 0, 0.0, float(f_char), run.name, md)
    data = RunData(inputs, F, keep)
    return RecordMeasurement(run.name, data, exc, spans, bounds, run.path, md)


RECORD = RecordKind()
