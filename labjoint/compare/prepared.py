"""A run ready for comparison: model inputs, the steady cycles and the loop result.

Made by :func:`labjoint.compare.runs.prepare_run`; read by the noise floor, residuals,
diagnosis and ladders (its own module so those need not import the preparation).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.identify import LoopResult
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
