"""The asymmetry an even effect describes, in numbers and in words: which side of rest is
stiffer and by how much.

Per even effect in a model (:mod:`labjoint.models.effects.even`), with k the model's
linear_stiffness (0 without one) and U the largest displacement amplitude of the data:

- quadratic_stiffness: secant stiffness at +U and -U, k_plus = k + k2 U, k_minus = k - k2 U;
- bilinear_stiffness: the two slopes, k_plus = k + dk, k_minus = k;
- contact: the slope beyond the closed contact on its side, k + |k_c|, against k on the
  other (and where it closes, +-g, and whether the data reach it).

>>> from labjoint.models.composition import Model
>>> a = asymmetry(Model.parse("linear_stiffness+bilinear_stiffness"),
...               {"linear_stiffness.k": 1e6, "bilinear_stiffness.dk": 2.5e5}, 1e-5)
>>> a[0]["stiffer_side"], round(a[0]["ratio"], 3)
('+u', 1.25)
>>> a[0]["text"]
'bilinear_stiffness: the +u side is stiffer, 1.25e+06 N/m against 1e+06 N/m on the -u side (25 % stiffer)'
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from labjoint.models.composition import Model
from labjoint.models.inputs import RunData

EVEN = ("quadratic_stiffness", "bilinear_stiffness", "contact")


def amplitude(runs: Sequence[RunData]) -> float:
    """The largest displacement amplitude (half the range) over the judged samples (m)."""
    out = 0.0
    for r in runs:
        u = r.inputs.u[r.steady]
        if u.size:
            out = max(out, 0.5 * float(np.ptp(u)))
    return out


def _value(params: Mapping[str, Any], key: str) -> float:
    p = params.get(key, 0.0)
    return float(getattr(p, "value", p))


def _words(name: str, k_plus: float, k_minus: float, how: str = "") -> dict[str, Any]:
    if k_plus == k_minus:
        return {"effect": name, "stiffer_side": None, "k_plus": k_plus, "k_minus": k_minus,
                "ratio": 1.0, "text": f"{name}: both sides equally stiff{how}"}
    plus = k_plus > k_minus
    hi, lo = (k_plus, k_minus) if plus else (k_minus, k_plus)
    side, other = ("+u", "-u") if plus else ("-u", "+u")
    ratio = hi / lo if lo > 0 else None
    rel = (f"{100 * (ratio - 1):.3g} % stiffer" if ratio is not None
           else f"{hi - lo:.3g} N/m stiffer; the {other} side's {lo:.3g} N/m is not positive")
    return {"effect": name, "stiffer_side": side, "k_plus": k_plus, "k_minus": k_minus,
            "ratio": ratio,
            "text": f"{name}: the {side} side is stiffer, {hi:.3g} N/m against {lo:.3g} N/m "
                    f"on the {other} side{how} ({rel})"}


def asymmetry(model: Model, params: Mapping[str, Any], amplitude_m: float) -> list[dict[str, Any]]:
    """One entry per even effect of ``model`` (module docstring): ``effect``,
    ``stiffer_side`` ("+u", "-u" or None), ``k_plus``, ``k_minus`` (N/m), ``ratio``
    (stiffer over softer, None when the softer is not positive) and ``text``."""
    k = _value(params, "linear_stiffness.k") if "linear_stiffness" in model.names else 0.0
    U = float(amplitude_m)
    out = []
    for name in model.names:
        if name == "quadratic_stiffness":
            k2 = _value(params, "quadratic_stiffness.k2")
            out.append(_words(name, k + k2 * U, k - k2 * U,
                              f" (secant stiffness at +-{U:.3g} m)"))
        elif name == "bilinear_stiffness":
            out.append(_words(name, k + _value(params, "bilinear_stiffness.dk"), k))
        elif name == "contact":
            kc, g = _value(params, "contact.k_c"), _value(params, "contact.gap")
            beyond = k + abs(kc)
            at = f"+{g:.3g}" if kc >= 0 else f"-{g:.3g}"
            reach = "within" if g < U else "beyond"
            how = (f" once the contact closes at u = {at} m ({reach} the largest amplitude "
                   f"{U:.3g} m)")
            d = _words(name, beyond if kc >= 0 else k, k if kc >= 0 else beyond, how)
            d["gap_m"] = g
            out.append(d)
    return out
