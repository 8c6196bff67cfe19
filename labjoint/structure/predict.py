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
from scipy.linalg import lu_factor, lu_solve

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
        self._warm: dict[tuple, np.ndarray] = {}
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
        """(step index, w, force phasor, HBM solution, solver) in sweep order per sweep."""
        hb = HarmonicBalance(self.system_with(law), H, max(self.samples, 8 * H))
        for (_, d), idx in frfset.groups():
            x = None
            for k in idx:
                f, F = frfset.frequencies_hz[k], frfset.force[k]
                key = (H, d, float(f), float(abs(F)))
                x = hb.solve(2 * np.pi * f, float(abs(F)), x0=self._warm.get(key, x) if warm else x,
                             tol=self.tol)
                self._warm[key] = x
                yield k, 2 * np.pi * f, F, x, hb

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
        for k, w, F, x, hb in self._steps(frfset, law, H, warm):
            ph = hb.phasors(x, rows)[h] * np.exp(1j * h * np.angle(F))[:, None]   # (h, S) displacement
            out[k, :, :h.size] = convert(ph, h * w, frfset.quantity).T
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
        for k, w, F, x, hb in self._steps(frfset, law, H, True):
            _, J = hb.residual(x, w, float(abs(F)), jacobian=True)
            X = x.reshape(hb.m, hb.sys.n)
            sel = hb.sys.selectors
            dR = np.zeros((x.size, len(names)))
            for group in hb.groups:                   # the joints of one law in one call
                Qg = np.vstack([X @ sel[e] for e in group])
                G0 = hb._forces(group[0], Qg, w)
                for j, (hbj, d) in enumerate(zip(pert, steps)):
                    dG = (hbj._forces(group[0], Qg, w) - G0) / d
                    for i, e in enumerate(group):
                        dR[:, j] += np.outer(dG[i], sel[e]).ravel()
            lu = lu_factor(J)
            # one right-hand side at a time: a multi-column solve goes to level-3 BLAS, whose
            # threads spin on a shared machine (44 ms against 0.1 ms per step, measured)
            dx = -np.column_stack([lu_solve(lu, dR[:, j]) for j in range(len(names))])
            rot = np.exp(1j * hh * np.angle(F))[:, None]
            out[k, :, :hh.size] = convert(hb.phasors(x, rows)[hh] * rot, hh * w, frfset.quantity).T
            for j in range(len(names)):
                dph = hb.phasors(dx[:, j], rows)[hh] * rot
                dout[k, :, :hh.size, j] = convert(dph, hh * w, frfset.quantity).T
        return out, dout

    def predict_rows(self, frfset: FrfSet, law: JointLaw | None, rows: np.ndarray) -> np.ndarray:
        """(n, r) harmonic-1 phasors of ``rows`` of the system's coordinates (e.g. the
        joints' selectors: their relative rotations) at the set's steps."""
        out = np.zeros((len(frfset), np.atleast_2d(rows).shape[0]), complex)
        for k, _, F, x, hb in self._steps(frfset, law, 1, True):
            out[k] = hb.phasors(x, rows)[1] * np.exp(1j * np.angle(F))
        return out


def convert(ph: np.ndarray, hw: np.ndarray, quantity: str) -> np.ndarray:
    """Displacement phasors (rows at angular frequencies ``hw``) to ``quantity``."""
    if quantity == "acceleration":
        return -(hw ** 2)[:, None] * ph
    if quantity == "velocity":
        return 1j * hw[:, None] * ph
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
