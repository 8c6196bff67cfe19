"""Why two candidate effects can be indistinguishable on some data: the physics, per pair.

>>> "viscous" in tie_reason("channel_delay", "viscous", 0.0071, 0.0072, 0.0006, 0.99)
True
"""

from __future__ import annotations

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
