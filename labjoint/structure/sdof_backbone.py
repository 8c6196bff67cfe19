"""Single-degree-of-freedom modal backbone of any joint law (where no structure is given).

The mode is m u'' + c u' + k u + g(u) = 0, u the joint's relative displacement (m) and
g any effect expression of :mod:`labjoint.models` (evaluated by
:class:`~labjoint.structure.law.JointLaw`, the effects' own code, along the steady loop
u = A cos(theta), theta = w t, with its hysteretic history; Masing laws close their
loop after one period). From the loop at amplitude A:

    first-harmonic (describing-function) stiffness  k1(A) = (1 / (pi A)) int_0^2pi g cos(theta) dtheta
    secant stiffness (Masing: the loop's tip)        ks(A) = g(A) / A
    dissipated energy per cycle                      W(A)  = oint g du = -A int_0^2pi g sin(theta) dtheta

and, with K(A) = k + k1 (``stiffness="harmonic"``, the default: what a one-harmonic
balance and the extended periodic motion concept give) or k + ks (``"secant"``, the
Masing-rule reading of the issue),

    w(A) = sqrt(K(A) / m),   zeta(A) = (W(A) + pi c w A^2) / (2 pi K(A) A^2),

the equivalent damping ratio of energy dissipated per cycle over 2 pi times the peak
potential energy's double, K A^2 (so a viscous c alone gives c / (2 m w)). A
rate-dependent law (viscous, inertia) is evaluated at w(A), found by fixed-point
iteration. The amplitude is u's (the joint's) or, with ``scale``, a sensor's
``scale * A`` (the mode shape's ratio, sensor over joint).
"""

from __future__ import annotations

import math

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.backbone import Backbone, BackbonePoint
from labjoint.structure.law import JointLaw
from labjoint.structure.system import LawElement, NonlinearSystem

SAMPLES = 256


def loop_terms(law: JointLaw, A: float, w: float, samples: int = SAMPLES) -> tuple[float, float, float]:
    """(k1, ks, W) of ``law`` on the steady loop u = A cos(w t) (module docstring)."""
    th = 2 * np.pi * np.arange(samples) / samples
    u, v, a = A * np.cos(th), -A * w * np.sin(th), -A * w * w * np.cos(th)
    g = law.periodic(u, v, a, samples * w / (2 * np.pi))[0]
    k1 = 2.0 * float(np.mean(g * np.cos(th))) / A
    W = -2.0 * np.pi * A * float(np.mean(g * np.sin(th)))
    return k1, float(g[0]) / A, W


def sdof_backbone(law: JointLaw, amplitudes, mass_kg: float, *, stiffness_n_per_m: float = 0.0,
                  damping_ns_per_m: float = 0.0, stiffness: str = "harmonic", scale: float = 1.0,
                  units: str = "m", sensor: str = "joint") -> Backbone:
    """Backbone points at ``amplitudes`` (m of u) of the single-DOF mode (module docstring)."""
    A = np.asarray(amplitudes, float)
    if A.ndim != 1 or A.size == 0 or not np.all(np.isfinite(A) & (A > 0)):
        raise InputError("amplitudes must be a non-empty list of positive numbers (m)", field="amplitudes")
    for name, v, lo in (("mass_kg", mass_kg, 0.0), ("stiffness_n_per_m", stiffness_n_per_m, None),
                        ("damping_ns_per_m", damping_ns_per_m, None), ("scale", scale, 0.0)):
        if not math.isfinite(v) or (lo is not None and v <= lo) or (lo is None and v < 0):
            raise InputError(f"must be a finite number{' > 0' if lo is not None else ' >= 0'}, got {v!r}",
                             field=name)
    if stiffness not in ("harmonic", "secant"):
        raise InputError(f"stiffness is 'harmonic' or 'secant', got {stiffness!r}", field="stiffness")
    k0 = stiffness_n_per_m + law.initial_stiffness()
    if k0 <= 0:
        raise InputError("the mode has no stiffness at rest (k + the law's initial stiffness <= 0)",
                         field="stiffness_n_per_m")
    pts = []
    for a in A:
        w = math.sqrt(k0 / mass_kg)
        for _ in range(20 if law.rate_dependent else 1):
            k1, ks, W = loop_terms(law, float(a), w)
            K = stiffness_n_per_m + (k1 if stiffness == "harmonic" else ks)
            if K <= 0:
                raise InputError(f"the joint carries no load at amplitude {a:.4g} m (stiffness "
                                 f"{K:.4g} N/m): no oscillation there", field="amplitudes")
            w_new = math.sqrt(K / mass_kg)
            if abs(w_new - w) < 1e-12 * w:
                break
            w = w_new
        w = w_new
        zeta = (W + np.pi * damping_ns_per_m * w * a * a) / (2 * np.pi * K * a * a)
        pts.append(BackbonePoint(scale * float(a), w / (2 * np.pi), float(zeta), f"sdof_{stiffness}",
                                 extra={"joint_amplitude_m": float(a), "dissipation_j": W}))
    return Backbone(pts, units, "displacement", sensor,
                    (f"single-DOF modal form, {stiffness} stiffness, m = {mass_kg:g} kg, "
                     f"k = {stiffness_n_per_m:g} N/m, c = {damping_ns_per_m:g} N s/m, law "
                     f"{law.model.expr}",))


class SdofPredictor:
    """The single-DOF modal form as the comparison's predictor, where no structure is
    described: m u'' + c u' + k u + g(u) = 0 (module docstring) as a
    :class:`~labjoint.structure.system.NonlinearSystem` with one output ``sensor`` (u
    itself), so the backbone kind's extended periodic motion concept
    (:mod:`labjoint.structure.epmc`) gives its backbone at any ``harmonics`` (1: the
    first-harmonic stiffness and energy of the module docstring). It offers what
    :class:`~labjoint.structure.predict.FrfPredictor` offers the backbone kind: the law
    in place (``law``), ``system_with(law)``, ``law_of`` and the stuck natural frequency.
    """

    structure = None
    modes = None

    def __init__(self, law: JointLaw, mass_kg: float, *, stiffness_n_per_m: float = 0.0,
                 damping_ns_per_m: float = 0.0, harmonics: int = 1, samples: int = 64,
                 sensor: str = "joint") -> None:
        for name, v, lo in (("mass_kg", mass_kg, 0.0), ("stiffness_n_per_m", stiffness_n_per_m, None),
                            ("damping_ns_per_m", damping_ns_per_m, None)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or \
                    (lo is not None and v <= lo) or (lo is None and v < 0):
                raise InputError(f"must be a finite number{' > 0' if lo is not None else ' >= 0'}, "
                                 f"got {v!r}", field=name)
        if isinstance(harmonics, bool) or not isinstance(harmonics, int) or harmonics < 1:
            raise InputError(f"must be a whole number >= 1, got {harmonics!r}", field="harmonics")
        self.law = law
        self.mass_kg, self.stiffness = float(mass_kg), float(stiffness_n_per_m)
        sysm = NonlinearSystem.sdof(self.mass_kg, float(damping_ns_per_m), self.stiffness, law)
        self.system = NonlinearSystem(sysm.M, sysm.C, sysm.K, sysm.force, sysm.selectors, sysm.elements,
                                      sysm.outputs, (str(sensor),))
        self.harmonics = int(harmonics)
        self.samples = int(max(samples, 8 * self.harmonics))

    def law_of(self, model, params) -> JointLaw:
        """The law ``model`` with ``params`` (``effect.param`` names), checked."""
        return JointLaw(model, params, field="joint")

    def system_with(self, law: JointLaw | None) -> NonlinearSystem:
        """The system with the law replaced by ``law`` (None: as built)."""
        if law is None:
            return self.system
        return NonlinearSystem(self.system.M, self.system.C, self.system.K, self.system.force,
                               self.system.selectors, (LawElement(law),), self.system.outputs,
                               self.system.output_names)

    def linear_damping_ratio(self, mode: int = 0) -> float:
        """The mode's damping ratio with the law stuck: c / (2 sqrt(k_0 m))."""
        if mode != 0:
            raise InputError(f"the single-DOF form has one mode; mode {mode + 1} asked", field="mode")
        k0 = self.stiffness + self.law.initial_stiffness()
        return float(self.system.C[0, 0] / (2 * math.sqrt(max(k0, 0.0) * self.mass_kg)))

    def with_damping_scale(self, scale: float) -> SdofPredictor:
        """The same form with its dashpot c times ``scale``; this one unchanged."""
        if not (math.isfinite(scale) and scale > 0):
            raise InputError(f"the damping scale must be > 0, got {scale!r}", field="linear_damping")
        return SdofPredictor(self.law, self.mass_kg, stiffness_n_per_m=self.stiffness,
                             damping_ns_per_m=float(self.system.C[0, 0]) * scale, harmonics=self.harmonics,
                             samples=self.samples, sensor=self.system.output_names[0])

    def natural_frequencies(self, n: int = 1) -> np.ndarray:
        """The mode's frequency (Hz) with the law stuck (one mode: ``n`` is ignored beyond 1)."""
        k0 = self.stiffness + self.law.initial_stiffness()
        return np.array([math.sqrt(max(k0, 0.0) / self.mass_kg) / (2 * np.pi)])
