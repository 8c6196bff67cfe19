"""Kinds judged together: one fit and one diagnosis over measurements of several kinds.

FRF sweeps (:mod:`.frf`) and backbones (:mod:`.backbone`) of one structure both judge
the same thing, the joint law inside the structure's model (an
:class:`~labjoint.structure.predict.FrfPredictor`), each by residuals whitened by its own
uncertainties; so they share one residual vector (every entry a multiple of its
standard uncertainty), one NRMSE, one noise floor and one significance test, and a
candidate effect is judged on both kinds of evidence at once.

A :class:`CombinedKind` is made of the kinds it joins (:data:`COMBINABLE`, registered by
:func:`labjoint.compare.kinds.kind_of` for a set that mixes them). Each set-level
operation asks each part kind about its own measurements and joins the answers:
split (each kind's rule on its own), the significance test (against the stated noise,
``known_noise``), maps and failures (each kind's, in its own words),
evidence (each kind's sentence, on its own measurements), candidates (the structure's:
the FRF kind's), and the fit (:func:`labjoint.compare.kinds.frf_fit.fit_frf`, which
stacks every measurement's whitened residual; its starts come from the FRF sweeps). A
set with backbones but no FRF sweep is the backbone kind alone, not this one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from labjoint.compare.kinds.frf_fit import fit_frf
from labjoint.models import FitResult, Model

#: kind names that can be judged together: they share the structure's joint law as predictor
COMBINABLE = frozenset({"frf", "backbone"})


def _sub(ev: Any, names: set[str]) -> Any:
    """An Evaluation restricted to the named measurements."""
    return replace(ev, runs=tuple(r for r in ev.runs if r.name in names))


@dataclass(frozen=True)
class CombinedMaps:
    """The part kinds' residual maps, by kind name."""

    parts: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        d = {k: m.to_dict() for k, m in self.parts.items()}
        return {"kinds": d, "cells": [dict(c, kind=k) for k, m in d.items() for c in m.get("cells", [])]}

    def step_curves(self) -> list[dict[str, Any]]:
        """The parts' ladder-step curves (the backbones')."""
        return [c for m in self.parts.values() if hasattr(m, "step_curves") for c in m.step_curves()]


@dataclass(frozen=True)
class CombinedCurves:
    parts: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {k: c.to_dict() for k, c in self.parts.items()}


class CombinedKind:
    """Set-level operations over measurements of several kinds (module docstring)."""

    #: residuals whitened by stated uncertainties: candidates are tested against that noise
    #: whatever the number of units (:func:`labjoint.compare.significance.noise_test`)
    known_noise = True

    def __init__(self, kinds: dict[str, Any]) -> None:
        self.kinds = dict(sorted(kinds.items(), key=lambda kv: kv[0] != "frf"))   # frf first
        self.name = "+".join(self.kinds)

    def _by(self, items: Sequence[Any], key: Any = lambda x: x) -> dict[str, list[Any]]:
        out: dict[str, list[Any]] = {k: [] for k in self.kinds}
        for it in items:
            out[key(it).kind].append(it)
        return out

    def _evals(self, evals: Sequence[Any]) -> dict[str, list[Any]]:
        return self._by(evals, lambda e: e.run)

    def split(self, ms: Sequence[Any]) -> tuple[list, list, str]:
        fit, val, rules = [], [], []
        for k, part in self._by(ms).items():
            f, v, rule = self.kinds[k].split(part)
            fit += f
            val += v
            rules.append(f"{k}: {rule}")
        return fit, val, "; ".join(rules)

    def maps(self, evals: Sequence[Any], noise: dict[str, float]) -> CombinedMaps:
        return CombinedMaps({k: self.kinds[k].maps(e, noise) for k, e in self._evals(evals).items()})

    def curves(self, evals: Sequence[Any]) -> CombinedCurves:
        return CombinedCurves({k: self.kinds[k].curves(e) for k, e in self._evals(evals).items()})

    def loops(self, evals: Sequence[Any]) -> dict[str, dict[str, Any]]:
        return {}

    def failures(self, ev: Any, maps: CombinedMaps, curves: Any, floor: float,
                 factor: float) -> list[dict[str, Any]]:
        out = []
        for k, kind in self.kinds.items():
            names = {r.name for r in ev.runs if r.run.kind == k}
            part_curves = curves.parts.get(k) if isinstance(curves, CombinedCurves) else curves
            out += [dict(f, kind=k) for f in kind.failures(_sub(ev, names), maps.parts[k], part_curves,
                                                           floor, factor)]
        out.sort(key=lambda d: -d.get("score", 0.0))
        return out

    def evidence(self, effect: str, base: Any, cand: Any, base_maps: CombinedMaps,
                 cand_maps: CombinedMaps, fit: FitResult, validation: str) -> str:
        parts = []
        for k, kind in self.kinds.items():
            names = {r.name for r in base.runs if r.run.kind == k}
            text = kind.evidence(effect, _sub(base, names), _sub(cand, names), base_maps.parts[k],
                                 cand_maps.parts[k], fit, "")
            parts.append(f"{k}: {text.rstrip('; ')}")
        return "; ".join(parts + [validation])

    def candidates(self, model: Model, only: Sequence[str] | None) -> tuple[list[str], dict[str, str]]:
        return self.kinds["frf"].candidates(model, only)

    def inconclusive(self, cands: Sequence[Any], base_validation: float, fit_ms: Sequence[Any],
                     val_ms: Sequence[Any]) -> str | None:
        frf = self.kinds["frf"]
        return frf.inconclusive(cands, base_validation, [m for m in fit_ms if m.kind == "frf"],
                                [m for m in val_ms if m.kind == "frf"])

    def fit(self, model: Model | str, fit_ms: Sequence[Any], val_ms: Sequence[Any] = (),
            init: Any = None) -> FitResult:
        return fit_frf(model, fit_ms, val_ms, init)

