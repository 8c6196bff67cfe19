"""Linear modal analysis and stage-1 updating of the joint stiffness (seed 000 Eqs. 7-8).

Updating: the objective is Eq. 7, sum_i ((f_i - f_i,test) / f_i,test)^2 over the measured
modes, in one joint parameter p (the thin layer's E_e by default, shared by every
joint that has it). The eigen-sensitivity of Eq. 8 with Delta M = 0 gives
d lambda_i / dp = phi_i^T (dK/dp) phi_i for mass-normalised phi_i, so
d f_i / dp = phi_i^T (dK/dp) phi_i / (8 pi^2 f_i); dK/dp is the change of the joints'
linear stiffness per unit p. Gauss-Newton steps are taken in log p (stiffnesses span
decades) within seed 000's bounds [1e-5, 1.1] x the start value, each step at most a
factor 10, until the relative change of p is below ``tol``. A parameter that ends at a
bound, or moves without moving the frequencies, is refused by name, never returned as an
answer (issue 29 item 4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from labjoint.errors import InputError, LabjointError
from labjoint.structure.assembly import Structure
from labjoint.structure.joint import TRANSVERSE

BOUNDS = (1e-5, 1.1)
MAX_LOG_STEP = np.log(10.0)
#: a parameter that moved by more than this fraction must shift a frequency by at least
#: FREQ_MOVED (relative) on its own, else stage 1 refuses it as undetermined
MOVED = 0.01
FREQ_MOVED = 1e-4


@dataclass(frozen=True)
class Modes:
    """Natural frequencies (Hz, ascending) and mass-normalised mode shapes (columns)."""

    frequencies_hz: np.ndarray
    shapes: np.ndarray


def modes(structure: Structure, count: int | None = None, K: np.ndarray | None = None) -> Modes:
    """The linear structure's modes (all, or the lowest ``count``)."""
    K = structure.stiffness() if K is None else K
    sub = None if count is None else (0, min(count, structure.n) - 1)
    w2, phi = eigh(K, structure.M, subset_by_index=sub)
    return Modes(np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi), phi)


def default_parameter(structure: Structure) -> str:
    """E_e_pa when a joint has a seed-000 layer, else the first joint's stuck stiffness."""
    if not structure.joints:
        raise InputError("the structure has no joint to update", field="joints")
    if any(j.layer is not None and j.layer.E_p_pa is not None for j in structure.joints):
        return "E_e_pa"
    for name in ("richard_abbott.ke", "iwan.K_T", "coulomb.k", "bouc_wen.k0", "linear_stiffness.k"):
        if name in structure.joints[0].law.params:
            return name
    raise InputError("name the joint parameter to update", field="update.parameter")


def with_parameter(structure: Structure, name: str, value: float) -> Structure:
    """Every joint that has parameter ``name`` with that value."""
    joints = []
    for j in structure.joints:
        has = name in j.law.params or name == TRANSVERSE or (name == "E_e_pa" and j.layer is not None)
        joints.append(j.with_parameter(name, value) if has else j)
    return structure.with_joints(tuple(joints))


def parameter_value(structure: Structure, name: str) -> float:
    for j in structure.joints:
        if name in j.law.params or name == TRANSVERSE or (name == "E_e_pa" and j.layer is not None):
            return j.parameter(name)
    raise InputError(f"no joint has parameter '{name}'", field="update.parameter")


@dataclass(frozen=True)
class UpdateResult:
    """Stage-1 result: the parameter(s), the frequencies before and after, the history.
    ``parameter``/``initial``/``value``/``bounds`` are the first parameter's; ``values``
    etc. hold every updated parameter's."""

    parameter: str
    initial: float
    value: float
    bounds: tuple[float, float]
    measured_hz: np.ndarray
    initial_hz: np.ndarray
    updated_hz: np.ndarray
    history: list[dict]
    structure: Structure
    values: dict[str, float] | None = None
    initials: dict[str, float] | None = None
    all_bounds: dict[str, tuple[float, float]] | None = None

    def to_dict(self) -> dict:
        values = self.values or {self.parameter: self.value}
        initials = self.initials or {self.parameter: self.initial}
        bounds = self.all_bounds or {self.parameter: self.bounds}
        return {"parameters": {k: {"value": v, "initial": initials[k], "lower": bounds[k][0],
                                   "upper": bounds[k][1],
                                   "unit": "Pa" if k == "E_e_pa" else "N/m" if k == TRANSVERSE else "SI"}
                               for k, v in values.items()},
                "frequencies_hz": self.updated_hz.tolist(), "initial_frequencies_hz": self.initial_hz.tolist(),
                "measured_hz": self.measured_hz.tolist(),
                "objective": float(np.sum(((self.updated_hz - self.measured_hz) / self.measured_hz) ** 2)),
                "history": self.history}


def _with(structure: Structure, values: dict[str, float]) -> Structure:
    s = structure
    for k, v in values.items():
        s = with_parameter(s, k, v)
    return s


def _refuse_non_answers(structure: Structure, p0: dict[str, float], v: dict[str, float],
                        bounds: dict[str, tuple[float, float]], f_test: np.ndarray, f0: np.ndarray,
                        f: np.ndarray) -> None:
    """Refuse (InputError naming the parameter) a stage-1 result that is no answer: a
    parameter that ended at one of its bounds (the measured frequencies ask for more than
    it can give), or that moved (by more than ``MOVED``) while its own change, the others
    held at their starts, shifted no frequency by ``FREQ_MOVED`` (relative): the modes do
    not determine it."""
    where = (f"; modes {', '.join(f'{x:.4g}' for x in f)} Hz (from {', '.join(f'{x:.4g}' for x in f0)}) "
             f"against the measured {', '.join(f'{x:.4g}' for x in f_test)} Hz")
    for n, val in v.items():
        lo, hi = bounds[n]
        for edge, side in ((lo, "lower"), (hi, "upper")):
            if abs(np.log(val / edge)) < 1e-9:
                raise InputError(f"{n} ended at its {side} bound {edge:.4g} ({BOUNDS[side == 'upper']:g} x "
                                 f"the start {p0[n]:.4g}): not an answer, the model cannot reach the "
                                 f"measured frequencies with it{where}", field=n)
        if abs(np.log(val / p0[n])) > np.log(1.0 + MOVED):
            alone = modes(_with(structure, {**p0, n: val}), f_test.size).frequencies_hz
            base = modes(_with(structure, p0), f_test.size).frequencies_hz
            shift = float(np.max(np.abs(alone / base - 1.0)))
            if shift < FREQ_MOVED:
                raise InputError(f"{n} moved from {p0[n]:.4g} to {val:.4g} but left the frequencies "
                                 f"where they were (largest change {shift:.2g}, relative): the measured "
                                 f"modes do not determine it{where}", field=n)


def update_stiffness(structure: Structure, measured_hz: list[float] | np.ndarray,
                     parameter: str | list[str] | None = None, max_iter: int = 50,
                     tol: float = 1e-6) -> UpdateResult:
    """Eigen-sensitivity updating of one joint parameter, or of several (a list or
    ``"a,b"``: e.g. ``E_e_pa,transverse_stiffness_n_per_m``, the rotational and the
    translational stiffness, to place two modes), by Gauss-Newton in log p (module
    docstring). Parameters are applied in the order given."""
    f_test = np.asarray(measured_hz, float)
    if f_test.ndim != 1 or f_test.size == 0 or not np.all(np.isfinite(f_test) & (f_test > 0)):
        raise InputError("measured frequencies must be positive numbers", field="measured_hz")
    names = ([p.strip() for p in parameter.split(",") if p.strip()] if isinstance(parameter, str)
             else list(parameter) if parameter else [default_parameter(structure)])
    if len(names) > f_test.size:
        raise InputError(f"{len(names)} parameters need at least as many measured frequencies, got "
                         f"{f_test.size}", field="update.parameter")
    p0 = {n: parameter_value(structure, n) for n in names}
    for n, v in p0.items():
        if not v > 0:
            raise InputError(f"start value must be > 0, got {v:g}", field=n)
    lo = np.log([BOUNDS[0] * p0[n] for n in names])
    hi = np.log([BOUNDS[1] * p0[n] for n in names])
    m = f_test.size
    history = []
    x = np.log([p0[n] for n in names])
    s = structure
    f0 = None
    for it in range(max_iter + 1):
        p = dict(zip(names, np.exp(x).tolist()))
        s = _with(structure, p)
        K = s.stiffness()
        md = modes(s, m, K)
        f = md.frequencies_hz
        f0 = f if f0 is None else f0
        r = (f - f_test) / f_test
        J = np.zeros((m, len(names)))
        for c, n in enumerate(names):
            dp = 1e-6 * p[n]
            dK = (_with(structure, {**p, n: p[n] + dp}).stiffness() - K) / dp
            df_dp = np.einsum("ij,ik,kj->j", md.shapes, dK, md.shapes) / (8 * np.pi ** 2 * f)  # Eq. 8
            J[:, c] = df_dp * p[n] / f_test                       # d r / d log p
        history.append({"iteration": it, **p, "frequencies_hz": f.tolist(), "objective": float(r @ r)})
        dead = [n for c, n in enumerate(names) if not (J[:, c] @ J[:, c]) > 0]
        if dead:
            raise InputError(f"the frequencies do not depend on {dead[0]}: stage 1 cannot update it "
                             "(it would leave them where they were)", field=dead[0])
        step = np.clip(np.linalg.lstsq(J, -r, rcond=None)[0], -MAX_LOG_STEP, MAX_LOG_STEP)
        x_new = np.clip(x + step, lo, hi)
        if np.max(np.abs(x_new - x)) < tol:
            break
        x = x_new
    else:
        raise LabjointError(f"stage-1 updating of {', '.join(names)} did not converge in {max_iter} "
                            f"iterations (objective {history[-1]['objective']:.3g})")
    v = dict(zip(names, np.exp(x).tolist()))
    b = {n: (float(np.exp(a)), float(np.exp(c))) for n, a, c in zip(names, lo, hi)}
    _refuse_non_answers(structure, p0, v, b, f_test, f0, f)
    return UpdateResult(names[0], p0[names[0]], v[names[0]], b[names[0]], f_test, f0, f, history, s,
                        v, p0, b)
