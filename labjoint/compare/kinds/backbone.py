"""The ``backbone`` kind: a mode's natural frequency and damping ratio against amplitude.

Measurement (:class:`BackboneMeasurement`): the points of a measured
:class:`~labjoint.signal.backbone.Backbone` (phase resonance, ringdown, step sine) with
the structure they were measured on; the predictor is a joint model inside the
structure: every joint's law the model with its parameters
(:meth:`~labjoint.structure.predict.FrfPredictor.system_with`), the mode's backbone by
the extended periodic motion concept at the measured amplitudes and sensor
(:mod:`labjoint.structure.epmc`); for phase-resonance points (their force and apparent
modal mass recorded) the forced quadrature at the excitation point at those amplitudes
instead, the measurement's own definition (:mod:`labjoint.structure.phase_resonance`).

Residual: per point, frequency and damping ratio, model minus measured, over the
point's standard uncertainty (whitened). The core's "measured force" is the whitened
measured values, point by point [f_1 / sd_f,1, zeta_1 / sd_zeta,1, f_2 / sd_f,2, ...];
units (the paired test): ``BANDS`` contiguous bands of amplitude per measurement (low,
middle, high). The points are independent, but their improvements are far from normal
(a frequency misfit of hundreds of uncertainties beside a damping one of a few), which
the t-test over points reads as noise; with few units the core also tests the change of
the residual energy against the points' known unit variance
(:func:`labjoint.compare.significance.noise_test`), the test whitened data call for. Noise floor: the points' own
uncertainties; whitened, the equivalent std is 1 and the floor NRMSE 1 / rms of the
whitened measurement. The fit (:func:`fit_backbone`) is the FRF kind's search
(:func:`labjoint.structure.stage2.fit_law` with its starts) on these residuals.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from labjoint.compare.kinds.frf_fit import FRF_EFFECTS, NO_SOLUTION, SCALE_RANGE, physical_start, split_stiffness
from labjoint.compare.measurement import RunNoise
from labjoint.errors import InputError
from labjoint.models import FitResult, Model, Parameters, RunData
from labjoint.models.inputs import ModelInputs
from labjoint.models.scores import nrmse_from_sums, pooled_nrmse
from labjoint.signal.backbone import Backbone
from labjoint.structure.epmc import EPMC
from labjoint.structure.hbm import ConvergenceError
from labjoint.structure.law import JointLaw
from labjoint.structure.phase_resonance import phase_resonance_points
from labjoint.structure.predict import FrfPredictor
from labjoint.structure.stage2 import fit_law

METHOD = ("the backbone points' own standard uncertainties (residuals whitened by them: the "
          "floor is 1 / rms of the whitened measured values)")
#: an uncertainty is never taken below this fraction of its value
MIN_SD_FRACTION = 1e-6
#: amplitude bands per measurement: the units of the paired test
BANDS = 3


@dataclass(frozen=True, eq=False)
class BackboneMeasurement:
    """Points of one measured backbone, prepared (module docstring)."""

    kind: ClassVar[str] = "backbone"
    noise_method: ClassVar[str] = METHOD
    name: str
    backbone: Backbone
    predictor: FrfPredictor
    mode: int
    data: RunData
    sd: np.ndarray                       # (2P,) per point: frequency sd, damping sd
    harmonics: int = 3
    path: str | None = None
    samples: int = 32                    # AFT samples per period of the EPMC (>= 8 per harmonic)
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def amplitudes(self) -> np.ndarray:
        return self.backbone.array("amplitude")

    def units(self) -> np.ndarray:
        """``BANDS`` bands of consecutive points (by amplitude), as sample spans."""
        edges = 2 * np.unique(np.linspace(0, self.data.force.size // 2, min(BANDS, self.data.force.size // 2) + 1
                                          ).round().astype(int))
        return np.column_stack([edges[:-1], edges[1:]])

    def axes(self) -> dict[str, Any]:
        a = self.amplitudes
        return {"mode": self.mode + 1, "sensor": self.backbone.sensor, "points": int(a.size),
                "amplitude_min_m": float(a.min()), "amplitude_max_m": float(a.max())}

    def values(self, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whitened vector back to (frequency_hz, damping_ratio) per point."""
        v = vector * self.sd
        return v[0::2], v[1::2]

    def solve(self, law: JointLaw) -> tuple[np.ndarray, np.ndarray]:
        """The model's frequency (Hz) and damping ratio at the measured amplitudes, and
        each joint patch's largest slip amplitude (m)."""
        sysm = self.predictor.system_with(law)
        ep = EPMC(sysm, self.mode, self.harmonics, max(self.samples, 8 * self.harmonics), self.backbone.sensor)
        bb, sols = ep.backbone(self.amplitudes)
        fz = np.column_stack([bb.array("frequency_hz"), bb.array("damping_ratio")])
        if is_phase_resonance(self.backbone):   # the measurement's own definition on the model's side
            fz = phase_resonance_points(ep, self.amplitudes, sols)[:, :2]
        rot = ep.hb.phasors(sols[int(np.argmax(self.amplitudes)), :-2], sysm.selectors)[1]
        # a joint's coordinate is a rotation (slip = radius x rotation); a law element's is the slip
        r = max(e.joint.radius_m if hasattr(e, "joint") else 1.0 for e in sysm.elements)
        self.metadata["slip_amplitude_m"] = float(r * np.max(np.abs(rot)))
        return fz.ravel(), rot

    def predict_law(self, law: JointLaw) -> np.ndarray:
        return self.solve(law)[0] / self.sd

    def predict(self, model: Model, params: Parameters | dict) -> np.ndarray:
        """The model's whitened frequencies and damping ratios (the core's model force)."""
        vals = {k: float(v.value if hasattr(v, "value") else v) for k, v in params.items()}
        return self.predict_law(self.predictor.law_of(model, {k: vals[k] for k in model.param_names}))

    def figures(self, model_force: np.ndarray) -> dict[str, float]:
        """Frequency drop and damping rise over the measured amplitudes, measured and model."""
        out = {}
        for side, v in (("measured", self.data.force), ("model", model_force)):
            f, z = self.values(v)
            out[f"frequency_drop_{side}"] = float(1 - f[-1] / f[0])
            out[f"damping_rise_{side}"] = float(z[-1] / z[0]) if z[0] > 0 else float("nan")
        return out

    def noise(self) -> RunNoise:
        f = self.data.force
        rms = float(np.sqrt(np.mean(f * f)))
        return RunNoise(self.name, float("nan"), float("nan"), 1.0, 1.0 / rms if rms > 0 else float("nan"),
                        len(self.backbone.points), 0)

    def renamed(self, name: str) -> BackboneMeasurement:
        return replace(self, name=name, data=self.data.renamed(name))


def is_phase_resonance(backbone: Backbone) -> bool:
    """Whether every point is a phase-resonance point (compared with the model's forced
    quadrature; other methods with the EPMC)."""
    return bool(backbone.points) and all(p.method == "phase_resonance" for p in backbone.points)


def prepare_backbones(items: Sequence[Backbone | tuple[str, Backbone]], predictor: FrfPredictor,
                      mode: int = 0, harmonics: int = 3, split: bool = True,
                      samples: int = 32) -> list[BackboneMeasurement]:
    """Measurements of measured backbones (or (name, backbone) pairs) on the predictor's
    structure (or the single-DOF modal form, :class:`labjoint.structure.sdof_backbone.SdofPredictor`),
    the model's backbone by EPMC with ``harmonics`` and ``samples`` per period (a slip
    law's kink needs more samples than 32 where its backbone is known to 1e-5); with ``split`` each backbone gives two, its even and its odd points by
    amplitude, the largest amplitude always with the even ones (``NAME/even`` fits,
    ``NAME/odd`` validates between them: :class:`BackboneKind`)."""
    if not items:
        raise InputError("no backbones given", field="runs")
    out = []
    for i, item in enumerate(items):
        name, b = item if isinstance(item, tuple) else (f"backbone{i}", item)
        if not isinstance(b, Backbone) or not b.points:
            raise InputError(f"'{name}' is not a backbone with points", field="runs")
        if b.amplitude_units != "m" or b.quantity != "displacement":
            raise InputError(f"'{name}': amplitudes must be displacement in m (the EPMC's measure), "
                             f"got {b.quantity} in {b.amplitude_units}", field="runs")
        n = len(b.points)
        odd = [i for i in range(1, n - 1, 2)]            # the extremes fit: validation interpolates
        parts = [("even", [p for i, p in enumerate(b.points) if i not in odd]),
                 ("odd", [b.points[i] for i in odd])] if split and n >= 3 else [("all", b.points)]
        for tag, pts in parts:
            sub = replace(b, points=list(pts))
            f, z = sub.array("frequency_hz"), sub.array("damping_ratio")
            sd = np.column_stack([np.maximum(sub.array("frequency_sd_hz"), MIN_SD_FRACTION * f),
                                  np.maximum(sub.array("damping_sd"), MIN_SD_FRACTION * np.abs(z))]).ravel()
            y = np.column_stack([f, z]).ravel() / sd
            zero = np.zeros(y.size)
            nm = f"{name}/{tag}"
            inputs = ModelInputs(zero, zero, zero, 1.0, 0, 0.0, float(np.mean(f)), nm, {"kind": "backbone"})
            out.append(BackboneMeasurement(nm, sub, predictor, int(mode), RunData(inputs, y, np.ones(y.size, bool)),
                                           sd, int(harmonics), metadata={"part": tag},
                                           samples=int(samples)))
    return out


def fit_backbone(model: Model | str, fit_ms: Sequence[BackboneMeasurement],
                 val_ms: Sequence[BackboneMeasurement] = (), init: Any = None,
                 max_nfev: int | None = None) -> FitResult:
    """Fit ``model`` (every joint's law) to the fit measurements' whitened residuals."""
    model = Model.parse(model)
    bad = [n for n in model.names if n not in FRF_EFFECTS]
    if bad:
        raise InputError(f"{', '.join(bad)} cannot act as a joint law in the structure's harmonic "
                         f"balance; use {', '.join(FRF_EFFECTS)}", field="model")
    if not fit_ms:
        raise InputError("no backbone measurements to fit", field="runs")
    pr = fit_ms[0].predictor
    own = {k: v for k, v in pr.law.params.items() if k in model.param_names}
    prev = init.params_.valuesdict() if isinstance(init, FitResult) else dict(init or {})
    known = {**own, **{k: float(v) for k, v in prev.items() if k in model.param_names}}
    missing = [n for n in model.param_names if n not in known]
    start = known
    if missing:
        k_joint = pr.law.initial_stiffness()
        base = "+".join(n for n in model.names if all(p in known for p in Model.parse(n).param_names))
        base_law = pr.law_of(base or "linear_stiffness", physical_start(
            Model.parse(base or "linear_stiffness"), known, k_joint, 0.0, 1.0))
        top = max(fit_ms, key=lambda m: m.amplitudes.max())
        top.solve(base_law)
        start = split_stiffness(physical_start(model, known, k_joint, top.metadata["slip_amplitude_m"],
                                               float(pr.natural_frequencies(1)[0])), missing)
    law0 = pr.law_of(model, start)
    names = model.param_names
    last: list[np.ndarray] = []

    def residual(law) -> np.ndarray:
        try:
            r = np.concatenate([m.predict_law(law) - m.data.force for m in fit_ms])
        except (ConvergenceError, ValueError, np.linalg.LinAlgError):
            if not last:
                raise
            return NO_SOLUTION * last[0]
        last[:] = [r]
        return r

    lf = fit_law(law0, names, residual, None, max_nfev=max_nfev or 12 * len(names), scale_range=SCALE_RANGE)
    params = model.make_params(values=lf.values)
    for k in names:
        params[k].stderr = lf.stderr[k]
    sse, ssf = {}, {}
    for m in (*fit_ms, *val_ms):
        r = m.predict_law(lf.law) - m.data.force
        sse[m.name], ssf[m.name] = float(r @ r), float(m.data.force @ m.data.force)
    fn, vn = [m.name for m in fit_ms], [m.name for m in val_ms]
    return FitResult(model, params, tuple(names), dict(lf.stderr), lf.correlation,
                     pooled_nrmse([sse[n] for n in fn], [ssf[n] for n in fn]),
                     {n: nrmse_from_sums(sse[n], ssf[n]) for n in fn},
                     pooled_nrmse([sse[n] for n in vn], [ssf[n] for n in vn]) if vn else None,
                     {n: nrmse_from_sums(sse[n], ssf[n]) for n in vn}, lf.n_evals, True,
                     lf.message, int(sum(m.data.force.size for m in fit_ms)), 2 * lf.cost,
                     (), tuple(fn), tuple(vn))
