"""Set-level operations of the ``frf`` kind: split, residual maps over frequency x force
level x harmonic, where the model fails (which mode, which side of the resonance, which
level, which harmonic), what a candidate changes, the fitter and the candidates.

Split (seed 000's workflow): with steps around two modes, the mode-1 sweeps are fitted
and the others validate; around one mode with two or more levels, every second level
(in ascending order, starting from the second) validates, so the fit brackets it;
otherwise the sweeps alternate.

Residual map cell: per sweep, harmonic and step the rms over sensors of the whitened
residual (model minus measured phasor over its std per component); 1 is the noise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.compare.kinds.frf_fit import FRF_EFFECTS, fit_frf
from labjoint.compare.kinds.frf_verdict import inconclusive
from labjoint.compare.kinds.frf import FrfMeasurement
from labjoint.errors import InputError
from labjoint.models import FitResult, Model
from labjoint.structure.joint import refusal
from labjoint.vocabulary import EFFECTS

FAIL_RATIO = 2.0


@dataclass(frozen=True)
class FrfMaps:
    """Per sweep (measurement) and harmonic: frequencies, measured and model response per
    newton (|phasor| / |F|, first sensor), residual over noise (rms over sensors)."""

    cells: list[dict[str, Any]] = field(default_factory=list)

    def by_harmonic(self) -> dict[int, float]:
        """rms residual over noise per harmonic, all sweeps and steps pooled."""
        out: dict[int, list[float]] = {}
        for c in self.cells:
            out.setdefault(c["harmonic"], []).extend(np.square(c["residual_over_noise"]).tolist())
        return {h: float(np.sqrt(np.mean(v))) for h, v in sorted(out.items())}

    def to_dict(self) -> dict[str, Any]:
        return {"axes": ["frequency_hz", "level_n", "harmonic"], "cells": self.cells,
                "residual_over_noise_by_harmonic": {str(k): v for k, v in self.by_harmonic().items()}}


@dataclass(frozen=True)
class NoCurves:
    """The FRF kind draws FRFs (the maps), no loop curves."""

    def to_dict(self) -> dict[str, Any]:
        return {}


def frf_maps(evals: Sequence[Any]) -> FrfMaps:
    cells = []
    for ev in evals:
        m: FrfMeasurement = ev.run
        meas, mod = m.phasors(m.data.force), m.phasors(ev.model_force)
        res = (ev.model_force - m.data.force).reshape(len(m.frfset), len(m.frfset.sensors),
                                                      m.frfset.harmonics, 2)
        F = np.abs(m.frfset.force)
        for h in range(m.frfset.harmonics):
            cells.append({"run": m.name, "level_n": m.level_n, "direction": m.direction,
                          "mode": m.mode + 1, "harmonic": h + 1,
                          "sensor": m.frfset.sensors[0],
                          "frequency_hz": m.frfset.frequencies_hz.tolist(),
                          "measured_per_n": (np.abs(meas[:, 0, h]) / F).tolist(),
                          "model_per_n": (np.abs(mod[:, 0, h]) / F).tolist(),
                          "residual_over_noise": np.sqrt(np.mean(np.sum(res[:, :, h] ** 2, -1) / 2,
                                                                 axis=1)).tolist()})
    return FrfMaps(cells)


def _where(c: dict[str, Any]) -> str | None:
    r = np.asarray(c["residual_over_noise"])
    if r.size == 0 or np.sqrt(np.mean(r ** 2)) <= FAIL_RATIO:
        return None
    f = np.asarray(c["frequency_hz"])
    peak = f[int(np.argmax(c["measured_per_n"]))] if c["harmonic"] == 1 else None
    worst = int(np.argmax(r))
    side = ""
    if peak is not None:
        side = (" below" if f[worst] < peak else " above" if f[worst] > peak else " at") + \
            f" the measured resonance ({peak:.4g} Hz)"
    return (f"mode {c['mode']}, {c['level_n']:g} N {c['direction']}, harmonic {c['harmonic']}: "
            f"residual {np.sqrt(np.mean(r ** 2)):.3g}x the noise, worst {r[worst]:.3g}x at "
            f"{f[worst]:.4g} Hz{side}")


class FrfKind:
    """Set-level operations of FRF measurements (:class:`labjoint.compare.measurement.Kind`)."""

    name = "frf"

    def split(self, ms: Sequence[FrfMeasurement]) -> tuple[list, list, str]:
        modes = sorted({m.mode for m in ms})
        if len(modes) > 1:
            fit = [m for m in ms if m.mode == modes[0]]
            return fit, [m for m in ms if m.mode != modes[0]], \
                f"fit on the sweeps around mode {modes[0] + 1}, validate on the others (seed 000)"
        levels = sorted({m.level_n for m in ms})
        if len(levels) >= 3:
            val_lv = set(levels[1::2][:max(1, len(levels) // 2)]) - {levels[-1]}
            val = [m for m in ms if m.level_n in val_lv]
            return [m for m in ms if m.level_n not in val_lv], val, \
                "fit on every other force level, validate on the levels between them"
        if len(ms) >= 2:
            return list(ms[::2]), list(ms[1::2]), "sweeps alternate between fit and validation"
        return list(ms), [], "one sweep: fitted, not validated"

    def maps(self, evals: Sequence[Any], noise: dict[str, float]) -> FrfMaps:
        return frf_maps(evals)

    def curves(self, evals: Sequence[Any]) -> NoCurves:
        return NoCurves()

    def loops(self, evals: Sequence[Any]) -> dict[str, dict[str, Any]]:
        return {}

    def failures(self, ev: Any, maps: FrfMaps, curves: Any, floor: float,
                 factor: float) -> list[dict[str, Any]]:
        out = []
        for c in maps.cells:
            txt = _where(c)
            if txt:
                out.append({"where": f"{c['run']} h{c['harmonic']}", "text": txt,
                            "score": float(np.sqrt(np.mean(np.square(c["residual_over_noise"]))))})
        out.sort(key=lambda d: -d["score"])
        return out

    def evidence(self, effect: str, base: Any, cand: Any, base_maps: FrfMaps,
                 cand_maps: FrfMaps, fit: FitResult, validation: str) -> str:
        b, c = base_maps.by_harmonic(), frf_maps(cand.runs).by_harmonic()
        parts = ", ".join(f"harmonic {h} {b[h]:.3g} -> {c.get(h, float('nan')):.3g}" for h in b)
        return f"adding {effect}: residual over noise {parts}; {validation}"

    # -- what the core asks of a kind with its own predictor ---------------------------------
    def candidates(self, model: Model, only: Sequence[str] | None) -> tuple[list[str], dict[str, str]]:
        have = set(model.names)
        names = [n for n in EFFECTS if n not in have]
        if only is not None:
            unknown = [n for n in only if n not in EFFECTS]
            if unknown:
                raise InputError(f"unknown effect(s) {unknown}", field="candidates")
            names = [n for n in names if n in set(only)]
        hyst = any(e.kind == "hysteretic" for e in model.effects)
        skipped, out = {}, []
        for n in names:
            if n not in FRF_EFFECTS:
                skipped[n] = f"cannot act in a structure's joint: {refusal(n)}"
            elif only is None and n in ON_REQUEST:
                skipped[n] = ON_REQUEST[n]
            elif EFFECTS[n].kind == "modifier" and not hyst:
                skipped[n] = "scales slip strengths, but the model has no hysteretic part"
            else:
                out.append(n)
        return out, skipped

    def inconclusive(self, cands: Sequence[Any], base_validation: float,
                     fit_ms: Sequence[FrfMeasurement], val_ms: Sequence[FrfMeasurement]) -> str | None:
        return inconclusive(cands, base_validation, fit_ms, val_ms)

    def fit(self, model: Model | str, fit_ms: Sequence[FrfMeasurement],
            val_ms: Sequence[FrfMeasurement] = (), init: Any = None) -> FitResult:
        return fit_frf(model, fit_ms, val_ms, init)


#: effects that act in a joint but are tried only when named (--candidates): each fit in a
#: structure costs seconds, and these share the signature of the slip laws tried by default
ON_REQUEST = {n: "tried when named (--candidates): a hysteretic slip law with the signature of "
                 "coulomb, iwan and richard_abbott, which are tried by default" for n in ("bouc_wen", "valanis")}
ON_REQUEST["backlash"] = ("tried when named (--candidates): its gap acts on the whole joint law, "
                          "stiffness included; on the benchmark's set harmonic balance could not "
                          "follow a resonance from any start")

FRF = FrfKind()
