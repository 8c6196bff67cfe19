"""Evidence for a candidate effect, in words with numbers, and its physical explanation.

Evidence describes what adding the effect changes on the data: the character of the
force it adds (phase of its fundamental against the displacement's, its constant and
harmonic parts), how the residual varies with frequency (or amplitude) before and after,
which part of the residual it removes (constant, odd, even harmonics, drift), the
validation figures with the significance test, and the fitted parameters. The
explanation is the effect's own physical description and signature
(:mod:`labjoint.models.effects`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from labjoint.compare.metrics import Evaluation
from labjoint.compare.residuals import ResidualMaps, harmonic_parts
from labjoint.compare.runs import frequency_levels
from labjoint.models import FitResult
from labjoint.models.effects import get_effect

PARTS = {"constant": "constant (mean-force)", "odd": "odd-harmonic", "even": "even-harmonic",
         "drift": "cycle-to-cycle drift"}


def _p(x: float) -> str:
    return f"{100 * x:.2g}" if abs(x) < 0.1 else f"{100 * x:.3g}"


def added_force_character(base: Evaluation, cand: Evaluation) -> str:
    """Phase and harmonic content of F_candidate - F_base, from the run where it is largest."""
    best, best_pow = None, -1.0
    for rb, rc in zip(base.runs, cand.runs):
        d = (rc.model_force - rb.model_force)[rb.run.steady]
        pw = float(d @ d)
        if pw > best_pow:
            best, best_pow = (rb, rc), pw
    if best is None or best_pow <= 0:
        return "adds no force on the data"
    rb, rc = best
    run = rb.run
    groups = run.cycle_bounds()
    hd = harmonic_parts(rc.model_force - rb.model_force, groups)
    hu = harmonic_parts(run.data.inputs.u, groups)
    tot = hd["constant"] + hd["odd"] + hd["even"]
    if tot <= 0:
        return "adds no periodic force"
    fund = hd["per_harmonic"][1] / tot
    const = hd["constant"] / tot
    higher_odd = (hd["odd"] - hd["per_harmonic"][1]) / tot
    even = hd["even"] / tot
    ph = float(np.degrees(hd["phase_h"][0] - hu["phase_h"][0]))
    ph = (ph + 180.0) % 360.0 - 180.0
    if const > 0.5:
        kind = f"mostly a constant force ({100 * const:.0f} % of its power)"
    else:
        if abs(ph) < 30:
            rel = "in phase with displacement (stiffness-like)"
        elif abs(ph) > 150:
            rel = "in anti-phase with displacement (negative stiffness, mass-like)"
        elif ph > 0:
            rel = "leading displacement, in quadrature (loss-like)" if 60 <= ph <= 120 \
                else "leading displacement"
        else:
            rel = "lagging displacement, in quadrature" if -120 <= ph <= -60 else "lagging displacement"
        kind = f"{rel}: fundamental at {ph:+.0f} deg"
    extra = []
    if fund < 0.9 and const <= 0.5:
        extra.append(f"fundamental {100 * fund:.0f} %")
    if higher_odd > 0.05:
        extra.append(f"odd harmonics >= 3: {100 * higher_odd:.0f} %")
    if even > 0.05:
        extra.append(f"even harmonics: {100 * even:.0f} %")
    if 0.05 < const <= 0.5:
        extra.append(f"constant: {100 * const:.0f} %")
    where = f"{run.frequency_hz:g} Hz, {run.amplitude_m * 1e6:.3g} µm"
    return f"added force is {kind}" + (f" ({', '.join(extra)} of its power)" if extra else "") \
        + f" [largest at {where}]"


def trend(base: Evaluation, cand: Evaluation) -> str:
    """Pooled NRMSE by frequency (or amplitude tercile) before -> after."""
    runs = [r.run for r in base.runs]
    lev = frequency_levels(runs)
    groups: list[tuple[str, list[str]]] = []
    if lev.max() >= 1:
        for k in range(int(lev.max()) + 1):
            names = [r.name for r, lv in zip(runs, lev) if lv == k]
            f = np.median([r.frequency_hz for r, lv in zip(runs, lev) if lv == k])
            groups.append((f"{f:g}", names))
        label, unit = "frequency", "Hz"
    else:
        order = np.argsort([r.amplitude_m for r in runs])
        for part in np.array_split(order, min(3, order.size)):
            if part.size:
                groups.append((f"{np.median([runs[i].amplitude_m for i in part]) * 1e6:.3g}",
                               [runs[i].name for i in part]))
        label, unit = "amplitude", "µm"
    before = "/".join(_p(base.nrmse(g)) for _, g in groups)
    after = "/".join(_p(cand.nrmse(g)) for _, g in groups)
    keys = "/".join(k for k, _ in groups)
    return f"NRMSE by {label} {keys} {unit}: {before} % -> {after} %"


def removed_part(base_maps: ResidualMaps, cand_maps: ResidualMaps) -> str:
    """The residual part (constant, odd, even, drift) the candidate reduces most."""
    drops = {k: base_maps.harmonic[k] ** 2 - cand_maps.harmonic[k] ** 2 for k in PARTS}
    k = max(drops, key=lambda x: drops[x])
    if drops[k] <= 0:
        return "removes no part of the residual"
    return (f"reduces the {PARTS[k]} residual {_p(base_maps.harmonic[k])} % -> "
            f"{_p(cand_maps.harmonic[k])} %")


def fitted_params(fit: FitResult, effect: str) -> str:
    items = []
    for key, p in fit.params_.items():
        if key.split(".")[0] != effect:
            continue
        se = fit.stderr_.get(key)
        se_txt = f" +- {se:.2g}" if se is not None and np.isfinite(se) else ""
        items.append(f"{key} = {p.value:.4g}{se_txt} {p.unit}".rstrip())
    return "fitted " + ", ".join(items) if items else ""


def evidence(effect: str, base: Evaluation, cand: Evaluation, base_maps: ResidualMaps,
             cand_maps: ResidualMaps, fit: FitResult, validation: str) -> str:
    """The evidence sentence of a candidate (module docstring)."""
    parts: Sequence[str] = (added_force_character(base, cand), trend(base, cand),
                            removed_part(base_maps, cand_maps), validation,
                            fitted_params(fit, effect))
    return "; ".join(p for p in parts if p)


def explanation(effect: str) -> str:
    """The effect's physical description and its signature in data."""
    e = get_effect(effect)
    return f"{e.description} Signature: {e.signature}"
