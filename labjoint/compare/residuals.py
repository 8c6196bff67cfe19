"""Where a model fails: maps of the residual F_measured - F_model over the steady samples.

Every map is in NRMSE units: sqrt(sum e^2 over the samples of a cell / sum F^2 over all
steady samples of the set), so the cells of a partition add up in squares to the pooled
NRMSE (except the per-cell "rms" views, normalised by the cell's own samples).

- by run: NRMSE of each run on a frequency x amplitude grid (frequency classes within 2 %,
  amplitudes ranked within each class), with each run's noise floor;
- by phase: bins of the cycle from the displacement fundamental's upward zero crossing
  (0 = centre going up, 0.25 = positive reversal, 0.5 = centre going down, 0.75 = negative
  reversal); the rms and the signed mean residual of each bin;
- by quadrant of (sign of displacement about the loop centre, sign of velocity);
- near reversals (phase within ``REVERSAL_WIDTH`` of 0.25 or 0.75) against mid-stroke
  (within it of 0 or 0.5), per-sample rms of each;
- by harmonic: per run, each steady cycle of the residual resampled and Fourier-analysed
  (:func:`harmonic_parts`); the parts are the constant (harmonic 0), odd and even
  harmonics (of the mean cycle), the drift (a straight-line trend of the coefficients
  over the cycles: the loop changes from cycle to cycle) and the rest (noise, aperiodic);
  their squares add to NRMSE^2;
- over time: the NRMSE of each steady cycle of each run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.compare.metrics import Evaluation, RunEval
from labjoint.compare.runs import frequency_levels
from labjoint.signal.cycles import cycles

PHASE_BINS = 16
REVERSAL_WIDTH = 0.08
MAX_HARMONIC = 20
QUADRANTS = ("u>0, v>0 (loading to +)", "u>0, v<0 (unloading from +)",
             "u<0, v<0 (loading to -)", "u<0, v>0 (unloading from -)")


def parseval_weights(m: int) -> np.ndarray:
    """Weights of the rfft lines of m points in Parseval's sum: 1 for the constant (and
    the Nyquist line of even m), 2 for the others (each stands for itself and its mirror)."""
    w = np.full(m // 2 + 1, 2.0)
    w[0] = 1.0
    if m % 2 == 0:
        w[-1] = 1.0
    return w


def harmonic_parts(x: np.ndarray, groups: Sequence[np.ndarray], max_h: int = MAX_HARMONIC
                   ) -> dict[str, Any]:
    """Sums of squares of ``x`` over the given cycles (``groups``: fractional bounds of
    consecutive cycles) in its constant, odd, even, drift and rest parts, per harmonic, and
    each harmonic's phase (``phase_h[h - 1]`` of cos(h 2 pi s + phase), s the fraction of the
    cycle). Each cycle is resampled to M points (:func:`labjoint.signal.cycles.cycles`) and
    Fourier-analysed; the periodic part is the mean over cycles of each coefficient, the
    drift its straight-line trend over the cycles, the rest what remains; sums of squares
    are scaled from M points to the record's samples per cycle."""
    parts = [g for g in groups if g.size >= 2]
    if not parts:
        z = np.zeros(max_h + 1)
        return {"constant": 0.0, "odd": 0.0, "even": 0.0, "drift": 0.0, "rest": 0.0,
                "per_harmonic": z, "phase_h": z[1:]}
    per = float(np.mean(np.concatenate([np.diff(g) for g in parts])))
    m = max(16, int(round(per)))
    c = np.concatenate([cycles(x, g, m, check=False) for g in parts], axis=0)
    k_n = c.shape[0]
    C = np.fft.rfft(c, axis=1) / m
    w = parseval_weights(m)
    mean = C.mean(axis=0)
    k = np.arange(k_n) - 0.5 * (k_n - 1)
    kk = float(k @ k)
    slope = (k @ (C - mean)) / kk if kk > 0 else np.zeros_like(mean)
    scale = per                    # Parseval: one cycle of ~per samples holds per sum w |C|^2
    total = float(np.sum(c * c)) * per / m
    periodic = k_n * scale * w * np.abs(mean) ** 2
    drift_h = kk * scale * w * np.abs(slope) ** 2
    H = min(max_h, C.shape[1] - 1)
    per_h = np.zeros(max_h + 1)
    per_h[:H + 1] = periodic[:H + 1]
    odd = float(periodic[1::2].sum())
    even = float(periodic[2::2].sum())
    drift = float(drift_h.sum())
    rest = max(total - float(periodic.sum()) - drift, 0.0)
    phase = np.zeros(max_h)
    phase[:H] = np.angle(mean[1:H + 1])
    return {"constant": float(periodic[0]), "odd": odd, "even": even, "drift": drift,
            "rest": rest, "per_harmonic": per_h, "phase_h": phase}


def state_dict(quadrant_nrmse: np.ndarray, quadrant_rms: np.ndarray, reversal_rms: float,
               midstroke_rms: float) -> dict[str, Any]:
    """The maps over the motion's state (quadrant of (u, v); reversals against
    mid-stroke) as JSON sections, for every kind of measurement."""
    ratio = reversal_rms / midstroke_rms if midstroke_rms > 0 else float("inf")
    return {"by_quadrant": {"labels": list(QUADRANTS), "nrmse": quadrant_nrmse, "rms": quadrant_rms},
            "reversal": {"near_reversal_rms": reversal_rms, "mid_stroke_rms": midstroke_rms,
                         "ratio": ratio}}


@dataclass
class ResidualMaps:
    """The maps of the module docstring (arrays; :meth:`to_dict` for JSON)."""

    frequencies_hz: np.ndarray
    grid_amplitude_m: np.ndarray
    grid_nrmse: np.ndarray
    grid_noise: np.ndarray
    grid_runs: list[list[str | None]]
    phase_edges: np.ndarray
    phase_rms: np.ndarray
    phase_mean: np.ndarray
    quadrant_nrmse: np.ndarray
    quadrant_rms: np.ndarray
    reversal_rms: float
    midstroke_rms: float
    harmonic: dict[str, float]
    per_harmonic: np.ndarray
    cycle_nrmse: dict[str, np.ndarray] = field(default_factory=dict)
    run_harmonic: dict[str, dict[str, float]] = field(default_factory=dict)
    nrmse: float = float("nan")

    @property
    def reversal_ratio(self) -> float:
        """rms near reversals / rms mid-stroke."""
        return self.reversal_rms / self.midstroke_rms if self.midstroke_rms > 0 else float("inf")

    def to_dict(self) -> dict[str, Any]:
        return {
            "by_run": {"frequencies_hz": self.frequencies_hz, "amplitude_m": self.grid_amplitude_m,
                       "nrmse": self.grid_nrmse, "noise_floor": self.grid_noise,
                       "runs": self.grid_runs},
            "by_phase": {"edges": self.phase_edges, "rms": self.phase_rms, "mean": self.phase_mean},
            **state_dict(self.quadrant_nrmse, self.quadrant_rms, self.reversal_rms,
                         self.midstroke_rms),
            "by_harmonic": {**self.harmonic, "per_harmonic": self.per_harmonic},
            "over_time": {k: v for k, v in self.cycle_nrmse.items()},
        }


def _grid(evals: Sequence[RunEval], noise: dict[str, float]) -> tuple:
    levels = frequency_levels([r.run for r in evals])
    nf = int(levels.max()) + 1
    cols = max(int(np.sum(levels == k)) for k in range(nf))
    amp = np.full((nf, cols), np.nan)
    nr = np.full((nf, cols), np.nan)
    nz = np.full((nf, cols), np.nan)
    names: list[list[str | None]] = [[None] * cols for _ in range(nf)]
    freqs = np.zeros(nf)
    for k in range(nf):
        members = [r for r, lv in zip(evals, levels) if lv == k]
        members.sort(key=lambda r: r.run.amplitude_m)
        freqs[k] = float(np.median([r.run.frequency_hz for r in members]))
        for j, r in enumerate(members):
            amp[k, j], nr[k, j] = r.run.amplitude_m, r.nrmse
            nz[k, j] = noise.get(r.name, np.nan)
            names[k][j] = r.name
    return freqs, amp, nr, nz, names


def residual_maps(ev: Evaluation | Sequence[RunEval], noise: dict[str, float] | None = None,
                  phase_bins: int = PHASE_BINS) -> ResidualMaps:
    """Residual maps of an evaluated model (``noise``: run -> noise-floor NRMSE)."""
    evals = list(ev.runs if isinstance(ev, Evaluation) else ev)
    noise = noise or {}
    freqs, amp, nr, nz, names = _grid(evals, noise)
    edges = np.linspace(0.0, 1.0, phase_bins + 1)
    e2_bin = np.zeros(phase_bins)
    e_bin = np.zeros(phase_bins)
    n_bin = np.zeros(phase_bins)
    q_e2 = np.zeros(4)
    q_n = np.zeros(4)
    rev = np.zeros(2)
    mid = np.zeros(2)
    parts = {"constant": 0.0, "odd": 0.0, "even": 0.0, "drift": 0.0, "rest": 0.0}
    per_h = np.zeros(MAX_HARMONIC + 1)
    ssf_all = 0.0
    n_all = 0
    cyc: dict[str, np.ndarray] = {}
    run_h: dict[str, dict[str, float]] = {}
    for r in evals:
        run = r.run
        m = run.steady
        e = r.residual
        ph = run.phase()
        f = run.data.force
        ssf_all += float(f[m] @ f[m])
        n_all += int(m.sum())
        rms_f = float(np.sqrt(np.mean(f[m] ** 2)))
        b = np.clip(np.floor(ph[m] * phase_bins).astype(int), 0, phase_bins - 1)
        e2_bin += np.bincount(b, e[m] ** 2, phase_bins)
        e_bin += np.bincount(b, e[m] / rms_f, phase_bins)
        n_bin += np.bincount(b, None, phase_bins)
        u = run.data.inputs.u
        seg = u[m]
        centre = 0.5 * (seg.max() + seg.min())
        v = run.data.inputs.v[m]
        q = np.where(seg >= centre, np.where(v >= 0, 0, 1), np.where(v < 0, 2, 3))
        q_e2 += np.bincount(q, e[m] ** 2, 4)
        q_n += np.bincount(q, None, 4)
        d_rev = np.minimum(np.abs(ph[m] - 0.25), np.abs(ph[m] - 0.75))
        d_mid = np.minimum(np.minimum(ph[m], 1.0 - ph[m]), np.abs(ph[m] - 0.5))
        rev += [float(np.sum(e[m][d_rev < REVERSAL_WIDTH] ** 2)), float(np.sum(d_rev < REVERSAL_WIDTH))]
        mid += [float(np.sum(e[m][d_mid < REVERSAL_WIDTH] ** 2)), float(np.sum(d_mid < REVERSAL_WIDTH))]
        hp = harmonic_parts(e, run.cycle_bounds())
        for k in parts:
            parts[k] += hp[k]
        per_h[:hp["per_harmonic"].size] += hp["per_harmonic"]
        ssf_r = float(f[m] @ f[m])
        run_h[r.name] = {k: float(np.sqrt(hp[k] / ssf_r)) for k in parts}
        with np.errstate(invalid="ignore", divide="ignore"):
            cyc[r.name] = np.sqrt(r.unit_sse() / r.unit_ssf())
    mean_f2 = ssf_all / max(n_all, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        phase_rms = np.sqrt(e2_bin / n_bin / mean_f2)
        phase_mean = e_bin / n_bin
        quad_rms = np.sqrt(q_e2 / q_n / mean_f2)
    return ResidualMaps(
        frequencies_hz=freqs, grid_amplitude_m=amp, grid_nrmse=nr, grid_noise=nz, grid_runs=names,
        phase_edges=edges, phase_rms=phase_rms, phase_mean=phase_mean,
        quadrant_nrmse=np.sqrt(q_e2 / ssf_all), quadrant_rms=quad_rms,
        reversal_rms=float(np.sqrt(rev[0] / max(rev[1], 1) / mean_f2)),
        midstroke_rms=float(np.sqrt(mid[0] / max(mid[1], 1) / mean_f2)),
        harmonic={k: float(np.sqrt(v / ssf_all)) for k, v in parts.items()},
        per_harmonic=np.sqrt(per_h / ssf_all), cycle_nrmse=cyc, run_harmonic=run_h,
        nrmse=float(np.sqrt(sum(r.sse for r in evals) / ssf_all)))
