"""A joint law inside a structure, predicting a measured set of constant-force FRFs.

:class:`FrfPredictor` holds the structure's nonlinear system once (Craig-Bampton reduced,
:mod:`labjoint.structure.reduction`) and swaps the joints' law for every evaluation, so
one prediction costs only the harmonic-balance solves at the measured steps: each sweep
(a level and a direction of the :class:`~labjoint.signal.frfset.FrfSet`) is solved in
its sweep order, each step from the previous one's solution (a step sine follows its
branch through a jump as the rig does), at the step's achieved force amplitude |F_k|.
The model's phasors are rotated by the achieved force's phase at each harmonic
(exp(i h arg F_k)), and converted to the set's quantity: acceleration -(h w)^2 X,
velocity i h w X, displacement X (the structure's phasor convention, :mod:`.hbm`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.signal.frfset import FrfSet
from labjoint.structure.assembly import Structure
from labjoint.structure.frf import DEFAULT_MODES, system_of
from labjoint.structure.hbm import HarmonicBalance
from labjoint.structure.law import JointLaw
from labjoint.structure.modal import modes as modal_modes
from labjoint.structure.system import JointElement, NonlinearSystem

MAX_HARMONICS = 5
SAMPLES = 64
#: relative residual of the harmonic balance solves (a measured phasor is known to ~1e-3)
TOL = 1e-7
#: start a step from the first-order prediction of the last parameter derivatives (and
#: reuse a step solved with the same law); False: from the last solution (benchmarks compare)
SLOPE_START = True
#: relative step of a law parameter in dR/dp (the floor for parameters at zero)
FD_PARAM, FD_FLOOR = 1e-6, 1e-12


class FrfPredictor:
    """Model FRFs of ``structure`` at the steps of FRF sets (module docstring)."""

    def __init__(self, structure: Structure, modes: int | None = DEFAULT_MODES,
                 harmonics: int = 3, samples: int = SAMPLES,
                 system: NonlinearSystem | None = None) -> None:
        if not structure.joints:
            raise InputError("the structure has no joint whose law could be compared", field="joints")
        self.structure = structure
        self.system = system if system is not None else system_of(structure, modes)
        self.modes = modes
        self.harmonics = int(harmonics)
        self.samples = int(max(samples, 8 * self.harmonics))
        self.law = structure.joints[0].law
        self._natural: np.ndarray | None = None
        self._warm: dict[tuple, tuple[tuple, np.ndarray]] = {}
        self._slopes: tuple | None = None
        self.tol = TOL

    def natural_frequencies(self, n: int = 2) -> np.ndarray:
        """The first ``n`` natural frequencies (Hz) with the joints stuck (linear)."""
        if self._natural is None or self._natural.size < n:
            self._natural = np.asarray(modal_modes(self.structure, n).frequencies_hz, float)
        return self._natural[:n]

    def law_of(self, model: Model | str, params: Mapping[str, float]) -> JointLaw:
        """The law ``model`` with ``params`` (``effect.param`` names), checked."""
        return JointLaw(model, params, field="joint")

    def system_with(self, law: JointLaw | None) -> NonlinearSystem:
        """The system with every joint's tangential law replaced by ``law`` (None: as built)."""
        if law is None:
            return self.system
        els = tuple(JointElement(replace(e.joint, law=law)) for e in self.system.elements)
        return replace(self.system, elements=els)

    def linear_damping_ratio(self, mode: int = 0) -> float:
        """Mode ``mode``'s (0: the first) damping ratio with the joints stuck: phi^T C phi /
        (2 w phi^T M phi) of the undamped mode of K with every joint's stuck stiffness (the
        light-damping value, linear in C: what :meth:`with_damping_scale` scales)."""
        from scipy.linalg import eigh

        s = self.system
        w2, phi = eigh(s.linear_stiffness(), s.M)
        if not 0 <= mode < w2.size:
            raise InputError(f"the model has {w2.size} modes; mode {mode + 1} asked", field="mode")
        v = phi[:, mode]
        return float(v @ s.C @ v / (2 * np.sqrt(max(w2[mode], 0.0)) * (v @ s.M @ v)))

    def with_damping_scale(self, scale: float) -> FrfPredictor:
        """A predictor of the same structure with its linear damping matrix C times
        ``scale`` (every mode's light-damping ratio times ``scale``); this one unchanged."""
        if not (np.isfinite(scale) and scale > 0):
            raise InputError(f"the damping scale must be > 0, got {scale!r}", field="linear_damping")
        out = FrfPredictor(self.structure, self.modes, self.harmonics, self.samples,
                           system=replace(self.system, C=self.system.C * float(scale)))
        out._natural = self._natural
        out.tol = self.tol
        return out

    def rows(self, sensors: tuple[str, ...]) -> np.ndarray:
        names = list(self.system.output_names)
        missing = [s for s in sensors if s not in names]
        if missing:
            raise InputError(f"sensor(s) {', '.join(missing)} of the FRF set are not sensors of "
                             f"the structure ({', '.join(names)})", field="sensors")
        return np.array([names.index(s) for s in sensors])

    def _steps(self, frfset: FrfSet, law: JointLaw | None, H: int, warm: bool):
        """(step index, w, force phasor, HBM solution, solver) in sweep order per sweep.

        With ``warm``, a step solved before with the same law is not solved again, and a
        step of a law whose parameter derivatives :meth:`predict_jacobian` made starts from
        the first-order prediction x + dx/dp (p - p0) (the search's next trial is near)."""
        hb = HarmonicBalance(self.system_with(law), H, max(self.samples, 8 * H))
        sig = _signature(law)
        dp, slopes = self._prediction(law, H) if warm and SLOPE_START else (None, {})
        for (_, d), idx in frfset.groups():
            x = None
            for k in idx:
                f, F = frfset.frequencies_hz[k], frfset.force[k]
                key = (H, d, float(f), float(abs(F)))
                old = self._warm.get(key) if warm else None
                if old is not None and old[0] == sig and SLOPE_START:
                    x = old[1]
                else:
                    x0 = x if old is None else old[1]
                    if key in slopes:
                        x0 = slopes[key][0] + slopes[key][1] @ dp
                    x = hb.solve(2 * np.pi * f, float(abs(F)), x0=x0, tol=self.tol)
                    self._warm[key] = (sig, x)
                yield k, 2 * np.pi * f, F, x, hb

    def _prediction(self, law: JointLaw | None, H: int) -> tuple[np.ndarray | None, dict]:
        """The parameter change from the last :meth:`predict_jacobian`'s law, and its
        per-step (x, dx/dp), if ``law`` differs from it only in those parameters."""
        if law is None or self._slopes is None:
            return None, {}
        expr, names, p0, fixed, H0, slopes = self._slopes
        if H0 != H or law.model.expr != expr or any(law.params[n] != v for n, v in fixed.items()):
            return None, {}
        return np.array([law.params[n] for n in names]) - p0, slopes

    def predict(self, frfset: FrfSet, law: JointLaw | None = None,
                harmonics: int | None = None, warm: bool = True) -> np.ndarray:
        """(n, S, H) model response phasors at the set's steps, in its quantity (SI).

        ``warm``: start each step from its solution of the previous call where there is
        one (a fit's next parameters differ little; 1-2 Newton iterations instead of the
        continuation from the previous step); otherwise from the previous step."""
        H_out = frfset.harmonics
        H = int(min(max(harmonics or self.harmonics, 1), MAX_HARMONICS))
        rows = self.system.outputs[self.rows(frfset.sensors)]
        out = np.zeros((len(frfset), len(frfset.sensors), H_out), complex)
        h = np.arange(1, min(H, H_out) + 1)
        steps = list(self._steps(frfset, law, H, warm))
        if not steps:
            return out
        ks, ws, Fs, xs, hbs = zip(*steps)
        ws, Fs = np.array(ws), np.array(Fs)
        # every step's phasors at once: (steps, h, S) displacement, rotated by the force's phase
        Y = np.stack(xs).reshape(len(xs), hbs[0].m, hbs[0].sys.n) @ rows.T
        ph = (Y[:, 2 * h - 1] - 1j * Y[:, 2 * h]) * np.exp(1j * h[None, :] * np.angle(Fs)[:, None])[:, :, None]
        out[np.array(ks), :, :h.size] = convert(ph, h[None, :] * ws[:, None], frfset.quantity).transpose(0, 2, 1)
        return out

    def predict_jacobian(self, frfset: FrfSet, law: JointLaw, names: tuple[str, ...],
                         harmonics: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`predict` and its derivative in the law parameters ``names``, (n, S, H, P):
        at each step's solution x the implicit function theorem gives
        dx/dp = -(dR/dx)^-1 dR/dp, with dR/dx the harmonic balance's Jacobian and dR/dp
        the change of the joints' force coefficients at fixed x (one law evaluation per
        parameter, no Newton solve), instead of a whole prediction per parameter."""
        H_out = frfset.harmonics
        H = int(min(max(harmonics or self.harmonics, 1), MAX_HARMONICS))
        rows = self.system.outputs[self.rows(frfset.sensors)]
        hh = np.arange(1, min(H, H_out) + 1)
        N = max(self.samples, 8 * H)
        steps = [FD_PARAM * max(abs(law.params[n]), FD_FLOOR) for n in names]
        pert = [HarmonicBalance(self.system_with(law.with_params(**{n: law.params[n] + d})), H, N)
                for n, d in zip(names, steps)]
        out = np.zeros((len(frfset), len(frfset.sensors), H_out), complex)
        dout = np.zeros(out.shape + (len(names),), complex)
        slopes: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        for k, w, F, x, hb in self._steps(frfset, law, H, True):
            dx = hb.sensitivity(x, w, float(abs(F)), pert, steps)
            slopes[(H, frfset.direction[k], float(frfset.frequencies_hz[k]), float(abs(F)))] = (x, dx)
            rot = np.exp(1j * hh * np.angle(F))[:, None]
            ph = hb.phasors(np.column_stack([x, dx]), rows)[hh] * rot[:, :, None]   # (h, S, 1+P)
            c = convert(ph.reshape(hh.size, -1), hh * w, frfset.quantity).reshape(ph.shape)
            out[k, :, :hh.size] = c[:, :, 0].T
            dout[k, :, :hh.size] = c[:, :, 1:].transpose(1, 0, 2)
        same = self._slopes is not None and self._slopes[:2] == (law.model.expr, tuple(names)) \
            and np.array_equal(self._slopes[2], [law.params[n] for n in names]) and self._slopes[4] == H
        self._slopes = (law.model.expr, tuple(names), np.array([law.params[n] for n in names]),
                        {n: v for n, v in law.params.items() if n not in names}, H,
                        {**(self._slopes[5] if same else {}), **slopes})
        return out, dout

    def predict_rows(self, frfset: FrfSet, law: JointLaw | None, rows: np.ndarray) -> np.ndarray:
        """(n, r) harmonic-1 phasors of ``rows`` of the system's coordinates (e.g. the
        joints' selectors: their relative rotations) at the set's steps."""
        out = np.zeros((len(frfset), np.atleast_2d(rows).shape[0]), complex)
        for k, _, F, x, hb in self._steps(frfset, law, 1, True):
            out[k] = hb.phasors(x, rows)[1] * np.exp(1j * np.angle(F))
        return out


def _signature(law: JointLaw | None) -> tuple:
    """What makes two laws the same law (None: the structure's own)."""
    return (None,) if law is None else (law.model.expr, tuple(law.params.values()))


def convert(ph: np.ndarray, hw: np.ndarray, quantity: str) -> np.ndarray:
    """Displacement phasors (rows at angular frequencies ``hw``; any leading axes) to ``quantity``."""
    if quantity == "acceleration":
        return -(hw ** 2)[..., None] * ph
    if quantity == "velocity":
        return 1j * hw[..., None] * ph
    return ph


def synthetic_frfset(predictor: FrfPredictor, law: JointLaw | None, frequencies_hz,
                     levels_n, sensors: tuple[str, ...] | None = None, harmonics: int = 3,
                     noise: float = 0.01, floor: float = 0.0, seed: int = 0,
                     directions: tuple[str, ...] = ("up",)) -> FrfSet:
    """An FRF set computed from the model with a known law and complex Gaussian noise:
    per phasor std ``noise`` x |harmonic-1 phasor of that sensor and step| + ``floor``
    (m/s^2), the same std stored as ``response_std`` (E|e|^2 = std^2). Reference data with
    known parameters (tests, benchmarks) until measured sets are at hand."""
    f = np.asarray(frequencies_hz, float)
    sensors = tuple(sensors or predictor.system.output_names)
    rng = np.random.default_rng(seed)
    fs, lv, dr = [], [], []
    for level in levels_n:
        for d in directions:
            fs.append(f if d == "up" else f[::-1])
            lv.append(np.full(f.size, float(level)))
            dr += [d] * f.size
    ff, ll = np.concatenate(fs), np.concatenate(lv)
    force = ll.astype(complex)
    clean = FrfSet(ff, ll, dr, force, sensors, np.ones((ff.size, len(sensors), harmonics), complex),
                   np.zeros((ff.size, len(sensors), harmonics)))
    r = predictor.predict(clean, law, harmonics)
    std = noise * np.abs(r[:, :, :1]) + floor + np.zeros(r.shape)
    e = (rng.standard_normal(r.shape) + 1j * rng.standard_normal(r.shape)) * std / np.sqrt(2)
    return FrfSet(ff, ll, dr, force, sensors, r + e, std,
                  metadata={"synthetic": True, "noise_relative": noise, "noise_floor": floor})
