"""Why two candidate effects can be indistinguishable on some data: the physics, per pair;
which candidates of a diagnosis are tied (:func:`mark_ties`), and their order (the one
with fewer parameters first, :func:`simpler_first`).

>>> "viscous" in tie_reason("channel_delay", "viscous", 0.0071, 0.0072, 0.0006, 0.99)
True
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.compare.significance import (SignificanceSettings, correlation, nrmse_se,
                                           paired_test)
from labjoint.vocabulary import EFFECTS

#: frozenset({a, b}) -> the physical reason and what data would separate them
KNOWN = {
    frozenset({"viscous", "channel_delay"}): (
        "a force channel leading by tau shows a joint of stiffness k as F + k tau du/dt, "
        "i.e. viscous damping c = k tau, at one frequency; the two differ only at second "
        "order in omega tau (a stiffness change -k (omega tau)^2 / 2) and in the phase of "
        "higher harmonics, so data at several, well separated frequencies separate them"),
    frozenset({"inertia", "linear_stiffness"}): (
        "at one frequency a mass is a negative stiffness -m omega^2; only several "
        "frequencies separate them"),
    frozenset({"inertia", "channel_delay"}): (
        "both change the apparent stiffness with frequency; separated by the loss a delay "
        "adds and inertia does not"),
    frozenset({"offset", "asymmetric_slip"}): (
        "both shift the loop's mean force; asymmetric slip's shift follows the slip "
        "(amplitude), an offset is the same at every amplitude, so a wider amplitude range "
        "separates them"),
    frozenset({"bilinear_stiffness", "contact"}): (
        "a contact whose gap is (nearly) zero is a bilinear stiffness: both add a slope on "
        "one side of rest; amplitudes below the gap, where a contact carries nothing, "
        "separate them"),
    frozenset({"quadratic_stiffness", "bilinear_stiffness"}): (
        "both stiffen one side of rest: smoothly (k2 u^2, a 2nd harmonic growing with the "
        "square of the amplitude) or with a kink at rest (in proportion to it); a wider "
        "amplitude range separates them"),
    frozenset({"cubic_stiffness", "bouc_wen"}): (
        "a hardening Bouc-Wen law (alpha + beta < 0) with little loss bends the loop like "
        "a cubic spring; its loss and the shape of its branches (data into the hysteretic "
        "range, or of another frequency) separate them"),
    frozenset({"cubic_stiffness", "saturating_stiffness"}): (
        "below its saturation a tanh spring is a linear plus a cubic one (k_s x_s tanh(u/x_s) "
        "= k_s u - k_s u^3 / (3 x_s^2) + ...); amplitudes well beyond x_s, where the "
        "saturating law levels off and a cubic keeps bending, separate them"),
    frozenset({"iwan", "saturating_stiffness"}): (
        "both soften the joint with amplitude and level off (micro-slip's elastic part); "
        "the slip law's loss per cycle, which the saturating law does not have, separates "
        "them"),
    frozenset({"cubic_stiffness", "backlash"}): (
        "both make the apparent stiffness rise with amplitude; backlash leaves a flat waist "
        "at small displacement, visible with larger amplitude range or smaller amplitudes"),
}


def tie_reason(a: str, b: str, nrmse_a: float, nrmse_b: float, uncertainty: float,
               corr: float) -> str:
    """A sentence: the numbers that make it a tie, and the physics if the pair is known."""
    text = (f"{a} and {b} cannot be told apart on these data: validation NRMSE "
            f"{100 * nrmse_a:.3g} % vs {100 * nrmse_b:.3g} % differ by less than the "
            f"uncertainty {100 * uncertainty:.2g} %, and the forces they add are "
            f"{100 * corr:.1f} % correlated")
    known = KNOWN.get(frozenset({a, b}))
    if known:
        return f"{text}; {known}"
    kinds = {EFFECTS[a].kind, EFFECTS[b].kind}
    if kinds == {"hysteretic"}:
        return (f"{text}; both are hysteretic slip laws whose loops coincide over this "
                "amplitude range; a wider amplitude range (into macro-slip) separates them")
    return f"{text}; data over a wider range of amplitude and frequency may separate them"


def mark_ties(cands: list[Any], base_ev: Any, val: list[str], floor: float,
              s: SignificanceSettings, known: bool = False) -> None:
    """Mark pairs that cannot be told apart on these data (:mod:`.significance`). Where the
    noise is ``known`` (residuals whitened by stated uncertainties) the uncertainty of the
    difference is that noise's: the two residual energies differ by a deterministic part
    plus 2 sum(e (F_a - F_b)), of standard deviation 2 sigma ||F_a - F_b|| (the units'
    spread would read a backbone band's large misfit as scatter)."""
    base_f = {r.name: r.model_force for r in base_ev.subset(val)}
    ssf = sum(r.ssf for r in base_ev.subset(val))
    n = sum(int(np.count_nonzero(r.run.data.steady)) for r in base_ev.subset(val))
    sigma = floor * np.sqrt(ssf / max(n, 1))

    def added(c: Any) -> np.ndarray:
        return np.concatenate([(r.model_force - base_f[r.name])[r.run.data.steady]
                               for r in c.evaluation.subset(val)])

    useful = [c for c in cands if c.significant]
    for i, a in enumerate(useful):
        for bb in useful[i + 1:]:
            test = paired_test(np.concatenate([r.unit_sse() for r in a.evaluation.subset(val)]),
                               np.concatenate([r.unit_sse() for r in bb.evaluation.subset(val)]))
            diff = abs(a.nrmse_after_validation - bb.nrmse_after_validation)
            se = nrmse_se(test, a.nrmse_after_validation, bb.nrmse_after_validation, ssf)
            both = a.nrmse_after_validation + bb.nrmse_after_validation
            if known and ssf > 0 and both > 0:
                d = added(a) - added(bb)
                se = 2 * sigma * float(np.sqrt(d @ d)) / (ssf * both)
            unc = max(2 * se, s.tie_tol * floor)
            if diff > unc:
                continue
            rho = correlation(added(a), added(bb))
            if rho < s.tie_corr:
                continue
            why = tie_reason(a.effect, bb.effect, a.nrmse_after_validation,
                             bb.nrmse_after_validation, unc, rho)
            for x, y in ((a, bb), (bb, a)):
                if y.effect not in x.tie_with:
                    x.tie_with.append(y.effect)
                    x.tie_reason = why if not x.tie_reason else x.tie_reason


def simpler_first(cands: list[Any]) -> list[Any]:
    """Candidates in ranking order, where tied ones (:func:`mark_ties`) go by fewer parameters
    first (the simpler physical reading; then the lower validation NRMSE): the first name
    is the one a user and the ladder take, and a tie cannot tell the data's preference."""
    rest = list(cands)
    out: list[Any] = []
    while rest:
        head = rest[0]
        group = [c for c in rest if c is head or c.effect in head.tie_with]
        pick = min(group, key=lambda c: (len(c.fit.params_), c.nrmse_after_validation))
        if pick is not head and not pick.tie_reason.endswith("first)"):
            pick.tie_reason = (f"{pick.tie_reason} ({pick.effect} ranked first: "
                               f"{len(pick.fit.params_)} parameters against "
                               f"{len(head.fit.params_)}, the simpler reading first)")
        out.append(pick)
        rest.remove(pick)
    return out
