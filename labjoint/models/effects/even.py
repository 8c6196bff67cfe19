"""Even (asymmetric) elastic effects: quadratic_stiffness, bilinear_stiffness, contact.

A joint whose two sides differ (a preloaded contact that opens on one side, a gap, a rough
interface) answers +u and -u differently: F(-u) != -F(u). For a sinusoidal displacement
its force then holds even harmonics (2nd, and a mean force), which no odd law (linear,
cubic, a symmetric slip law) produces. The three laws, u the relative displacement from
rest (the record's displacement zero):

- ``quadratic_stiffness``: F = k2 u^2. Beside linear_stiffness k the secant stiffness at
  +-U is k +- k2 U and the tangent stiffness k + 2 k2 u: k2 > 0 stiffens the +u side.
  For u = U sin(wt): F = k2 U^2 / 2 (1 - cos 2wt), a mean force and a 2nd harmonic of
  k2 U^2 / 2.
- ``bilinear_stiffness``: F = dk max(u, 0). Beside linear_stiffness k the slopes are
  k_minus = k (u < 0) and k_plus = k + dk (u > 0). One parameter, linear, so the fit
  solves it exactly; k_plus and k_minus as two free slopes would duplicate
  linear_stiffness (k u = k max(u, 0) + k min(u, 0)).
- ``contact``: one-sided contact across a gap: F = k_c max(sgn(k_c) u - g, 0), zero
  until the gap g >= 0 closes on the side given by the sign of k_c, then a contact
  stiffness |k_c| in parallel with the rest of the joint (k_c > 0: closes at u = +g,
  F = k_c (u - g) beyond; k_c < 0: closes at u = -g, F = -|k_c| (-u - g) beyond). The
  force is continuous in k_c through 0 (both sides vanish there). Distinct from
  ``backlash`` (kept as it is): backlash is a symmetric clearance of total width g in
  series with the whole joint (nothing carries load inside it); contact is an extra load
  path on one side only, the joint carrying load on both sides of rest meanwhile. With
  g = 0 it is bilinear_stiffness's law.

Every law is memoryless and elementwise on arrays of any shape (batched histories of the
structure's harmonic balance). Starting values come from least squares on the data
(:func:`labjoint.models.summary.even_terms`), never from zero.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects import _steady
from labjoint.models.effects.base import ElasticEffect, ForceEffect
from labjoint.models.inputs import ModelInputs
from labjoint.models.summary import LoopSummary

_SIGNATURE_EVEN = ("a 2nd harmonic and a mean force for a symmetric sinusoidal "
                   "displacement (F(-u) != -F(u)); the loop's two tips have different slopes")


class QuadraticStiffness(ForceEffect):
    """F = k2 u^2."""

    name = "quadratic_stiffness"
    steady_code = _steady.U_SQUARE
    description = (
        "An elastic restoring force that is stiffer on one side of rest than on the other and "
        "varies smoothly between them, F = k2 u^2 (with a linear k: secant stiffness k + k2 U "
        "at +U, k - k2 U at -U): a preloaded contact whose pressure grows as it is pushed "
        "one way and relaxes the other, a tilted or rough interface, a bolt bent by "
        "preload. Conservative: it bends the loop without opening it.")
    signature = ("A smooth even distortion: " + _SIGNATURE_EVEN + "; the 2nd harmonic of "
                 "the force grows with the square of the amplitude (k2 U^2 / 2).")

    def basis(self, inputs: ModelInputs) -> np.ndarray:
        return inputs.u_hist ** 2

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        return {"k2": float(summary.largest.k2)}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        r = summary.largest
        return {"k2": max(abs(guess["k2"]), 0.1 * abs(r.k_eq) / r.U, 1e-300)}


class BilinearStiffness(ForceEffect):
    """F = dk max(u, 0)."""

    name = "bilinear_stiffness"
    steady_code = _steady.U_RAMP
    description = (
        "The joint has one stiffness for u < 0 and another for u > 0, with a kink at rest: "
        "F = dk max(u, 0) beside a linear k gives k_minus = k and k_plus = k + dk (a contact "
        "closed at rest that opens to one side, a shim or a lap that bears on one face "
        "only). dk > 0: the +u side is stiffer.")
    signature = ("A loop bent at its centre: " + _SIGNATURE_EVEN + "; the 2nd harmonic "
                 "grows in proportion to the amplitude (the distortion's shape does not "
                 "change with level).")

    def basis(self, inputs: ModelInputs) -> np.ndarray:
        return np.maximum(inputs.u_hist, 0.0)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        r = summary.largest
        dk = r.k_plus - r.k_minus
        return {"dk": float(dk) if np.isfinite(dk) else 0.0}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"dk": max(abs(guess["dk"]), 0.1 * abs(summary.largest.k_eq), 1e-300)}


class Contact(ElasticEffect):
    """F = k_c max(sgn(k_c) u - g, 0): one-sided contact across a gap g."""

    name = "contact"
    needs_multistart = True
    description = (
        "A one-sided contact with a gap: nothing until the parts touch at u = +g (k_c > 0) "
        "or u = -g (k_c < 0), then a contact stiffness |k_c| in parallel with the joint, "
        "F = k_c max(sgn(k_c) u - g, 0): a fixture stop, a lap edge that bears on its "
        "neighbour, a rattling shim. Not backlash, which is a symmetric clearance in "
        "series with the whole joint.")
    signature = ("A stiffening on one side only, from a displacement on: " + _SIGNATURE_EVEN
                 + "; below the gap nothing (the distortion appears from an amplitude on), "
                 "then impacts put many harmonics, even and odd, into the force.")

    def elastic(self, params: Mapping[str, float], u: np.ndarray) -> np.ndarray:
        k, g = float(params["k_c"]), float(params["gap"])
        side = 1.0 if k >= 0 else -1.0
        return k * np.maximum(side * np.asarray(u, dtype=float) - g, 0.0)

    def steady_term(self, params: Mapping[str, float]) -> tuple[int, np.ndarray]:
        k = float(params["k_c"])
        return _steady.CONTACT, np.array([k, 1.0 if k >= 0 else -1.0, float(params["gap"])])

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        r = summary.largest
        return {"k_c": float(r.contact_k), "gap": float(max(r.contact_gap, 0.0))}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"k_c": max(abs(guess["k_c"]), 0.1 * abs(summary.largest.k_eq), 1e-300),
                "gap": max(guess["gap"], 0.1 * summary.smallest.U)}
