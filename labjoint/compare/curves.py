"""Measured-versus-model curves that tell the physics of a joint.

Per run (steady cycles): displacement amplitude U, frequency f, energy loss per cycle W
(seed 002 Eq. 1's loop area) and loop stiffness k, measured and model. Trends, measured
and model alike:

- dissipation against amplitude: the log-log slope d ln W / d ln U within each frequency
  (Segalman's micro-slip law W ~ U^(3 + chi), 2.5-3 for measured joints, seed 001; 2 for
  viscous or any linear loss, 1 for macro-slip);
- stiffness against amplitude: d k / d ln U relative to the mean k (softening < 0);
- dissipation against frequency: the exponent s_f of W ~ U^s_U f^s_f fitted over all runs
  (0 for friction, which is rate independent; 1 for viscous loss or a channel delay).

A loss below ``LOSSLESS`` of the largest measured loss of the set counts as none (a
stuck slider's loop has zero area up to rounding): such points are left out of the
log-log trends, which they would otherwise dominate, and are listed as ``lossless``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from labjoint.compare.metrics import Evaluation, RunEval
from labjoint.compare.runs import frequency_levels
from labjoint.signal.cycles import cycles

LOOP_POINTS = 128
LOSSLESS = 1e-3


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2 or np.ptp(x[ok]) < 1e-9:
        return float("nan")
    return float(np.polyfit(x[ok], y[ok], 1)[0])


def _log(x: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x > 0, np.log(np.where(x > 0, x, 1.0)), np.nan)


@dataclass
class PhysicsCurves:
    """Per-run points and their trends (module docstring); ``to_dict`` for JSON."""

    runs: list[str]
    frequency_hz: np.ndarray
    amplitude_m: np.ndarray
    energy_measured: np.ndarray
    energy_model: np.ndarray
    stiffness_measured: np.ndarray
    stiffness_model: np.ndarray
    levels: np.ndarray
    energy_slope: dict[str, dict[float, float]]
    stiffness_slope: dict[str, dict[float, float]]
    frequency_exponent: dict[str, float]
    lossless: dict[str, list[str]]

    def to_dict(self) -> dict[str, Any]:
        def keyed(d: dict[float, float]) -> dict[str, float]:
            return {f"{k:g}": v for k, v in d.items()}
        return {
            "runs": self.runs, "frequency_hz": self.frequency_hz, "amplitude_m": self.amplitude_m,
            "energy_loss_measured_j": self.energy_measured, "energy_loss_model_j": self.energy_model,
            "stiffness_measured_n_per_m": self.stiffness_measured,
            "stiffness_model_n_per_m": self.stiffness_model,
            "dissipation_vs_amplitude_slope": {k: keyed(v) for k, v in self.energy_slope.items()},
            "stiffness_vs_amplitude_slope": {k: keyed(v) for k, v in self.stiffness_slope.items()},
            "dissipation_vs_frequency_exponent": self.frequency_exponent,
            "lossless_runs": self.lossless,
        }


def physics_curves(ev: Evaluation | Sequence[RunEval]) -> PhysicsCurves:
    """The curves of an evaluated model."""
    evals = list(ev.runs if isinstance(ev, Evaluation) else ev)
    f = np.array([r.run.frequency_hz for r in evals])
    U = np.array([r.run.amplitude_m for r in evals])
    Em = np.array([r.energy_measured for r in evals])
    Ed = np.array([r.energy_model for r in evals])
    km = np.array([r.stiffness_measured for r in evals])
    kd = np.array([r.stiffness_model for r in evals])
    lev = frequency_levels([r.run for r in evals])
    big = float(np.nanmax(np.abs(Em))) if np.any(np.isfinite(Em)) else float("nan")
    lossless = {side: [evals[i].name for i in np.flatnonzero(E < LOSSLESS * big)]
                for side, E in (("measured", Em), ("model", Ed))}
    # loss-free points are left out of the trends (module docstring)
    Em_t = np.where(Em < LOSSLESS * big, np.nan, Em)
    Ed_t = np.where(Ed < LOSSLESS * big, np.nan, Ed)
    e_slope: dict[str, dict[float, float]] = {"measured": {}, "model": {}}
    k_slope: dict[str, dict[float, float]] = {"measured": {}, "model": {}}
    for k in range(int(lev.max()) + 1):
        sel = lev == k
        fk = float(np.median(f[sel]))
        for side, E, K in (("measured", Em_t, km), ("model", Ed_t, kd)):
            e_slope[side][fk] = _slope(_log(U[sel]), _log(E[sel]))
            s = _slope(_log(U[sel]), K[sel])
            mk = float(np.nanmean(K[sel])) if np.any(np.isfinite(K[sel])) else float("nan")
            k_slope[side][fk] = s / mk if mk else float("nan")
    fexp: dict[str, float] = {}
    for side, E in (("measured", Em_t), ("model", Ed_t)):
        y = _log(E)
        X = np.column_stack([np.ones_like(U), _log(U), _log(f)])
        ok = np.all(np.isfinite(X), axis=1) & np.isfinite(y)
        if int(lev.max()) >= 1 and ok.sum() >= 3:
            coef = np.linalg.lstsq(X[ok], y[ok], rcond=None)[0]
            fexp[side] = float(coef[2])
        else:
            fexp[side] = float("nan")
    return PhysicsCurves([r.name for r in evals], f, U, Em, Ed, km, kd, lev, e_slope, k_slope,
                         fexp, lossless)


def mean_loops(ev: Evaluation | Sequence[RunEval], n_points: int = LOOP_POINTS
               ) -> dict[str, dict[str, np.ndarray]]:
    """Measured-versus-model hysteresis loops: per run, the mean over its steady cycles of
    displacement, measured force and model force, each cycle resampled to ``n_points``
    from the displacement fundamental's upward zero crossing."""
    evals = list(ev.runs if isinstance(ev, Evaluation) else ev)
    out: dict[str, dict[str, np.ndarray]] = {}
    for r in evals:
        groups = r.run.cycle_bounds()
        if not groups:
            continue
        x = np.stack([r.run.data.inputs.u, r.run.data.force, r.model_force])
        cyc = np.concatenate([cycles(x, g, n_points) for g in groups], axis=1)
        mean = cyc.mean(axis=1)
        out[r.name] = {"displacement_m": mean[0], "force_measured_n": mean[1],
                       "force_model_n": mean[2]}
    return out
