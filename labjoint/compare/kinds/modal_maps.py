"""Set-level operations of the ``modal`` kind (:mod:`.modal`): split, residual maps per
record and channel (NRMSE and residual over the channel's noise), where the model
fails, what a candidate changes, the candidates (the effects that can act on a mode's
coordinate) and the fitter (:mod:`.modal_fit`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from labjoint.compare.kinds.modal import ModalMeasurement
from labjoint.compare.kinds.modal_fit import fit_modal
from labjoint.compare.kinds.modal_pair_fit import fit_modal_pair
from labjoint.compare.kinds.record_maps import TRACE_POINTS
from labjoint.errors import InputError
from labjoint.models import FitResult, Model
from labjoint.signal.frfset import RESPONSE_UNITS
from labjoint.structure.nlmode import MODAL_EFFECTS
from labjoint.vocabulary import EFFECTS


class ModalKind:
    """Set-level operations of modal records (:class:`labjoint.compare.measurement.Kind`).

    Split (stated): random/burst records (no frequency) are fitted; the steady sines,
    ordered by frequency (then by drive level), alternate: every second (from the second)
    validates, the others are fitted, so of any two neighbouring sines one is in each set
    and both sets cover every part of the band that two or more sines sample (the
    resonances and super-harmonic resonances where a joint's effects act: BERT's
    h3 at 6-6.5 Hz and h2 at 9.5 Hz). With fewer than two sines the records alternate.
    (Every third sine validating, as before, put 5.5, 6.75, 9, 17 and 20 Hz in BERT's
    validation: no sine of the 3rd-harmonic resonance, and a softening cubic was called
    not significant, p = 0.62.)"""

    name = "modal"

    def split(self, ms: Sequence[ModalMeasurement]) -> tuple[list, list, str]:
        sines = sorted([m for m in ms if m.frequency_hz],
                       key=lambda m: (m.frequency_hz, m.level if m.level is not None else 0.0))
        if len(sines) < 2:
            if len(ms) < 2:
                return list(ms), [], "one record: fitted, not validated"
            return list(ms[::2]), list(ms[1::2]), "records alternate between fit and validation"
        keep = {m.name for m in sines[1::2]}
        return [m for m in ms if m.name not in keep], [m for m in ms if m.name in keep], \
            ("sines ordered by frequency alternate between fit and validation (every second "
             "validates), so both sets cover the band; every record without a frequency fits")

    def maps(self, evals: Sequence[Any], noise: dict[str, float]) -> ModalMaps:
        cells = []
        for ev in evals:
            m: ModalMeasurement = ev.run
            sd = m.channel_noise()
            for i, ch in enumerate(m.channels):
                e = ev.model_force[m.channel_part(i)] - m.data.force[m.channel_part(i)]
                r = float(np.sqrt(np.mean(e * e))) if np.all(np.isfinite(e)) else float("inf")
                cells.append({"run": m.name, "channel": ch, "quantity": m.quantities[i],
                              "frequency_hz": m.frequency_hz, "level": m.level,
                              "nrmse": r, "residual_over_noise": r / sd[i] if sd[i] > 0 else None})
        return ModalMaps(cells)

    def curves(self, evals: Sequence[Any]) -> ModalMaps:
        return ModalMaps([])

    def loops(self, evals: Sequence[Any]) -> dict[str, dict[str, Any]]:
        return modal_traces(evals)

    def failures(self, ev: Any, maps: ModalMaps, curves: Any, floor: float,
                 factor: float) -> list[dict[str, Any]]:
        out = []
        for c in maps.cells:
            ron = c["residual_over_noise"]
            if ron is not None and ron > factor:
                at = f"{c['frequency_hz']:.4g} Hz sine" if c["frequency_hz"] else "record"
                out.append({"where": f"{c['run']} {c['channel']}", "score": float(ron),
                            "text": f"{c['channel']} ({c['quantity']}) on the {at}: NRMSE "
                                    f"{100 * c['nrmse']:.3g} %, {ron:.3g}x its noise"})
        out.sort(key=lambda d: -d["score"])
        return out

    def evidence(self, effect: str, base: Any, cand: Any, base_maps: ModalMaps,
                 cand_maps: ModalMaps, fit: FitResult, validation: str) -> str:
        b = base.nrmse() if hasattr(base, "nrmse") else float("nan")
        return (f"adding {effect} on mode 1: NRMSE {100 * b:.3g} % -> {100 * cand.nrmse():.3g} % "
                f"of the responses; {validation}")

    def candidates(self, model: Model, only: Sequence[str] | None) -> tuple[list[str], dict[str, str]]:
        if only is not None:
            unknown = [n for n in only if n not in EFFECTS]
            if unknown:
                raise InputError(f"unknown effect(s) {unknown}", field="candidates")
        have = set(model.names)
        out, skipped = [], {}
        for n in EFFECTS:
            if n in have or (only is not None and n not in only):
                continue
            if n not in MODAL_EFFECTS:
                skipped[n] = "cannot act on a mode's coordinate in the modal simulation"
            elif n == "asymmetric_slip" and "coulomb" not in have:
                skipped[n] = "acts on coulomb's slider, which the model lacks"
            elif n == "offset":
                skipped[n] = "a constant modal force moves no velocity or acceleration"
            else:
                out.append(n)
        return out, skipped

    def fit(self, model: Model | str, fit_ms: Sequence[ModalMeasurement],
            val_ms: Sequence[ModalMeasurement] = (), init: Any = None) -> FitResult:
        setup = fit_ms[0].setup if fit_ms else None
        kw = {"start": setup.start_dict, "bounds": setup.bounds_dict} if setup else {}
        if fit_ms and fit_ms[0].between:        # the joint between two sensors
            return fit_modal_pair(model, fit_ms, val_ms, init, max_nfev=self.max_nfev, **kw)
        return fit_modal(model, fit_ms, val_ms, init, max_nfev=self.max_nfev, **kw)

    max_nfev: int | None = None


def modal_traces(evals: Sequence[Any], n_points: int = TRACE_POINTS) -> dict[str, dict[str, Any]]:
    """Per record: every compared response, measured and model, over the judged span in
    its own SI unit (the mean removed, as compared), every k-th sample (at most
    ``n_points``), with their times."""
    out = {}
    for ev in evals:
        m: ModalMeasurement = ev.run
        n = m.judged.stop - m.judged.start
        step = max(1, int(np.ceil(n / n_points)))
        responses = {}
        for i, (ch, qty) in enumerate(zip(m.channels, m.quantities)):
            responses[ch] = {"quantity": qty, "unit": RESPONSE_UNITS.get(qty, ""),
                             "measured": m.in_units(i, m.data.force, step),
                             "model": m.in_units(i, ev.model_force, step)}
        out[m.name] = {"time_s": np.arange(m.judged.start, m.judged.stop, step) / m.drive.fs,
                       "responses": responses}
    return out


class ModalMaps:
    """Per record and channel: NRMSE and residual over its noise."""

    def __init__(self, cells: list[dict[str, Any]]) -> None:
        self.cells = cells

    def to_dict(self) -> dict[str, Any]:
        return {"axes": ["run", "channel"], "cells": self.cells}


MODAL = ModalKind()
