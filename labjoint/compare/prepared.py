"""A steady-sine run ready for comparison: model inputs, the steady cycles, the loop result.

The measurement of the ``sine`` kind (:mod:`labjoint.compare.measurement`,
:mod:`labjoint.compare.kinds.sine`). Made by :func:`labjoint.compare.runs.prepare_run`;
read by the noise floor, residuals, diagnosis and ladders (its own module so those need
not import the preparation).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from labjoint.compare.measurement import RunNoise
from labjoint.compare.noise import METHOD, lag_variance, quietest_variance, scatter_variance
from labjoint.identify import LoopResult
from labjoint.identify.loop import loop_metrics
from labjoint.models import RunData


@dataclass(frozen=True, eq=False)
class PreparedRun:
    """One run ready for comparison (SI units).

    ``data``: model inputs, measured force and the steady-sample mask; ``loop``: the
    hysteresis-loop result (per-cycle energy, stiffness, amplitudes, cycle bounds);
    ``cycle_ids``: indices (in ``loop``) of the steady cycles used; ``cycles``: their
    (start, stop) sample indices; ``transient``: steady cycles of the loop pipeline left out
    because their cycle-to-cycle scatter shows a passing transient; ``primed``:
    number of priming cycles prepended to the model history; ``offset``: index in the
    original record of sample 0 here (a primed record starts at its first steady cycle,
    so the priming begins at the loop's centre crossing).
    """

    kind: ClassVar[str] = "sine"
    noise_method: ClassVar[str] = METHOD
    name: str
    data: RunData
    loop: LoopResult
    cycle_ids: np.ndarray
    cycles: np.ndarray
    primed: int
    offset: int = 0
    transient: int = 0
    path: str | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def frequency_hz(self) -> float:
        return float(self.loop.frequency_hz)

    @property
    def fs(self) -> float:
        return float(self.data.inputs.fs)

    @property
    def amplitude_m(self) -> float:
        """Mean displacement amplitude over the steady cycles (m)."""
        return float(self.loop.summary["displacement_amplitude_m"])

    @property
    def force_amplitude_n(self) -> float:
        return float(self.loop.summary["force_amplitude_n"])

    @property
    def steady(self) -> np.ndarray:
        return self.data.steady

    @property
    def n_cycles(self) -> int:
        return int(self.cycles.shape[0])

    def units(self) -> np.ndarray:
        """The independent units: the steady cycles' (start, stop) samples."""
        return self.cycles

    def noise(self) -> RunNoise:
        """Noise over the steady cycles: force scatter plus the displacement's times the
        loop stiffness (:mod:`labjoint.compare.noise`)."""
        groups = self.cycle_bounds()
        var_f, n_cyc, n_win = scatter_variance(self.data.force, groups)
        lag = lag_variance(self.data.force, groups)     # few samples per cycle: see there
        if np.isfinite(lag) and np.isfinite(var_f) and lag < var_f:
            var_f = lag
        var_u = quietest_variance(self.data.inputs.u, groups)
        k = float(self.loop.summary["stiffness_n_per_m"])
        var_eq = var_f + (k * k * var_u if np.isfinite(var_u) else 0.0)
        f = self.data.force[self.steady]
        rms = float(np.sqrt(np.mean(f * f))) if f.size else float("nan")
        eq = float(np.sqrt(var_eq)) if np.isfinite(var_eq) else float("nan")
        return RunNoise(self.name, float(np.sqrt(var_f)), float(np.sqrt(var_u)), eq,
                        eq / rms if rms > 0 else float("nan"), n_cyc, n_win)

    def axes(self) -> dict[str, float]:
        return {"frequency_hz": self.frequency_hz, "displacement_amplitude_m": self.amplitude_m}

    def figures(self, model_force: np.ndarray) -> dict[str, float]:
        """Energy loss per cycle and loop stiffness, measured and model: means over the
        steady cycles of seed 002's loop quantities (Eq. 1 loop area; least-squares loop
        slope), both from the same displacement and estimator
        (:func:`labjoint.identify.loop.loop_metrics`)."""
        groups = self.cycle_bounds()
        u = self.data.inputs.u
        out = {}
        for side, f in (("measured", self.data.force), ("model", model_force)):
            parts = [loop_metrics(u, f, g, self.frequency_hz) for g in groups]
            for key, name in (("energy_loss", "energy_loss_{}_j"),
                              ("stiffness_lsq", "stiffness_{}_n_per_m")):
                x = np.concatenate([p[key] for p in parts]) if parts else np.zeros(0)
                x = x[np.isfinite(x)]
                out[name.format(side)] = float(np.mean(x)) if x.size else float("nan")
        return out

    def renamed(self, name: str) -> PreparedRun:
        return replace(self, name=name, data=self.data.renamed(name))

    def cycle_index(self) -> np.ndarray:
        """Per sample: index of its steady cycle (-1 outside them)."""
        idx = np.full(len(self.data.force), -1, dtype=np.int64)
        for k, (a, b) in enumerate(self.cycles):
            idx[a:b] = k
        return idx

    def phase(self) -> np.ndarray:
        """Per sample: fraction of its cycle in [0, 1) from the displacement fundamental's
        upward zero crossing (NaN outside the steady cycles)."""
        ph = np.full(len(self.data.force), np.nan)
        b = self.loop.bounds - self.offset
        used = self._used_cycles()
        for a, (s, e) in zip(used, self.cycles):
            x = np.arange(s, e, dtype=float)
            ph[s:e] = np.clip((x - b[a]) / (b[a + 1] - b[a]), 0.0, 1.0 - 1e-12)
        return ph

    def _used_cycles(self) -> np.ndarray:
        return self.cycle_ids

    def cycle_bounds(self) -> list[np.ndarray]:
        """Fractional bounds (record indexing) of the steady cycles whose interpolation
        neighbours lie inside the record, one array per group of consecutive cycles (for
        :func:`labjoint.identify.loop.loop_metrics` and :func:`labjoint.signal.cycles`)."""
        b = self.loop.bounds - self.offset
        n = len(self.data.force)
        ks = self._used_cycles()
        ks = ks[(b[ks] >= 1.0) & (b[ks + 1] <= n - 3)]
        if ks.size == 0:
            return []
        groups = np.split(ks, np.flatnonzero(np.diff(ks) > 1) + 1)
        return [b[g[0]:g[-1] + 2] for g in groups]
