"""Set-level operations of the ``backbone`` kind: split, residual maps over amplitude,
failures in the field's words, what a candidate changes, the fitter and the candidates.

Split: each measured backbone was prepared as its even and odd points by amplitude
(:func:`labjoint.compare.kinds.backbone.prepare_backbones`); the even ones are fitted
and the odd ones validate, so the validation interleaves the fitted amplitudes.

Residual map cell: per measurement and quantity (frequency, damping), per point the
whitened residual (model minus measured over the point's uncertainty); 1 is the noise.
Failures: the run of points up to the highest failing amplitude (|residual| >
``FAIL_RATIO``) whose residual keeps one sign, stated from its lowest amplitude:
"damping too low above x m" (the model dissipates too little there: a missing
micro-slip or friction effect), "damping too high" (its slip starts too early or is too
strong, or the structure's linear damping is too high), "frequency too high above x m: the
frequency drop starts too late or is too small", "frequency too low ... too early or
too large".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.compare.kinds.backbone import BackboneMeasurement, fit_backbone
from labjoint.compare.kinds.frf_maps import FRF
from labjoint.models import FitResult, Model

FAIL_RATIO = 3.0


@dataclass(frozen=True)
class BackboneMaps:
    cells: list[dict[str, Any]] = field(default_factory=list)

    def by_quantity(self) -> dict[str, float]:
        out: dict[str, list[float]] = {}
        for c in self.cells:
            out.setdefault(c["quantity"], []).extend(np.square(c["residual_over_noise"]).tolist())
        return {q: float(np.sqrt(np.mean(v))) for q, v in sorted(out.items())}

    def to_dict(self) -> dict[str, Any]:
        return {"axes": ["amplitude_m", "quantity"], "cells": self.cells,
                "residual_over_noise_by_quantity": self.by_quantity()}

    def step_curves(self) -> list[dict[str, Any]]:
        """The model's backbone at the measured amplitudes, one per measured backbone (its
        even and odd parts joined, amplitude ascending): what a ladder step draws."""
        joined: dict[str, dict[str, list[float]]] = {}
        for c in self.cells:       # cells come in pairs (frequency, damping) per measurement
            j = joined.setdefault(c["run"].rsplit("/", 1)[0], {})
            if c["quantity"] == "frequency_hz":
                j.setdefault("amplitude_m", []).extend(c["amplitude_m"])
            j.setdefault(c["quantity"], []).extend(c["model"])
        out = []
        for name, j in joined.items():
            order = np.argsort(j["amplitude_m"])
            out.append({"backbone": name, **{k: [float(j[k][i]) for i in order]
                                             for k in ("amplitude_m", "frequency_hz", "damping_ratio")}})
        return out


@dataclass(frozen=True)
class NoCurves:
    def to_dict(self) -> dict[str, Any]:
        return {}


def backbone_maps(evals: Sequence[Any]) -> BackboneMaps:
    cells = []
    for ev in evals:
        m: BackboneMeasurement = ev.run
        meas, mod = m.values(m.data.force), m.values(ev.model_force)
        res = ev.model_force - m.data.force
        for i, q in enumerate(("frequency_hz", "damping_ratio")):
            cells.append({"run": m.name, "quantity": q, "sensor": m.backbone.sensor,
                          "amplitude_m": m.amplitudes.tolist(), "measured": meas[i].tolist(),
                          "model": mod[i].tolist(), "residual_over_noise": res[i::2].tolist()})
    return BackboneMaps(cells)


def _where(c: dict[str, Any]) -> dict[str, Any] | None:
    r, a = np.asarray(c["residual_over_noise"]), np.asarray(c["amplitude_m"])
    bad = np.abs(r) > FAIL_RATIO
    if not bad.any():
        return None
    # the failure at the top of the amplitude range, and from which amplitude it holds
    top = int(np.flatnonzero(bad)[-1])
    sign = np.sign(r[top])
    first = top
    while first > 0 and bad[first - 1] and np.sign(r[first - 1]) == sign:
        first -= 1
    worst = first + int(np.argmax(np.abs(r[first:top + 1])))
    meas, mod = c["measured"][worst], c["model"][worst]
    if c["quantity"] == "damping_ratio":
        what = "damping too low" if sign < 0 else "damping too high"
        tail = (" (the model dissipates too little there: micro-slip or friction missing?)" if sign < 0
                else " (the model dissipates too much there: its slip starts too early or is too strong, "
                     "or the structure's linear damping is too high)")
        vals = f"model {mod:.4g} vs measured {meas:.4g}"
    else:
        what = "frequency too high" if sign > 0 else "frequency too low"
        tail = (": the frequency drop starts too late or is too small" if sign > 0
                else ": the frequency drop starts too early or is too large")
        vals = f"model {mod:.6g} Hz vs measured {meas:.6g} Hz"
    text = (f"{what} above {a[first]:.2g} m{tail}; worst {abs(r[worst]):.3g}x the uncertainty at "
            f"{a[worst]:.2g} m ({vals}) [{c['run']}]")
    return {"where": f"{c['run']} {c['quantity']}", "text": text,
            "score": float(np.sqrt(np.mean(r ** 2)))}


class BackboneKind:
    """Set-level operations of backbone measurements (:class:`labjoint.compare.measurement.Kind`)."""

    name = "backbone"
    #: residuals whitened by the points' stated uncertainties: the significance test
    #: against that noise whatever the number of units, as the combined kind's
    #: (:func:`labjoint.compare.significance.noise_test`; with 3 backbones x 3 bands the
    #: t-test alone read a 9x validation gain on the rig as p = 0.03)
    known_noise = True

    def split(self, ms: Sequence[BackboneMeasurement]) -> tuple[list, list, str]:
        fit = [m for m in ms if m.metadata.get("part") != "odd"]
        val = [m for m in ms if m.metadata.get("part") == "odd"]
        return fit, val, "fit on every other amplitude of each backbone, validate on the points between"

    def maps(self, evals: Sequence[Any], noise: dict[str, float]) -> BackboneMaps:
        return backbone_maps(evals)

    def curves(self, evals: Sequence[Any]) -> NoCurves:
        return NoCurves()

    def loops(self, evals: Sequence[Any]) -> dict[str, dict[str, Any]]:
        return {}

    def failures(self, ev: Any, maps: BackboneMaps, curves: Any, floor: float,
                 factor: float) -> list[dict[str, Any]]:
        out = [f for f in (_where(c) for c in maps.cells) if f]
        out.sort(key=lambda d: -d["score"])
        return out

    def evidence(self, effect: str, base: Any, cand: Any, base_maps: BackboneMaps,
                 cand_maps: BackboneMaps, fit: FitResult, validation: str) -> str:
        b, c = base_maps.by_quantity(), backbone_maps(cand.runs).by_quantity()
        parts = ", ".join(f"{q} {b[q]:.3g} -> {c.get(q, float('nan')):.3g}" for q in b)
        return f"adding {effect}: residual over the uncertainty {parts}; {validation}"

    def candidates(self, model: Model, only: Sequence[str] | None) -> tuple[list[str], dict[str, str]]:
        return FRF.candidates(model, only)

    def fit(self, model: Model | str, fit_ms: Sequence[BackboneMeasurement],
            val_ms: Sequence[BackboneMeasurement] = (), init: Any = None) -> FitResult:
        return fit_backbone(model, fit_ms, val_ms, init)


BACKBONE = BackboneKind()
