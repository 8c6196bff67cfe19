"""Linear modal analysis and stage-1 updating of the joint stiffness (seed 000 Eqs. 7-8).

Updating: the objective is Eq. 7, sum_i ((f_i - f_i,test) / f_i,test)^2 over the measured
modes, in one joint parameter p (the thin layer's E_e by default, shared by every
joint that has it). The eigen-sensitivity of Eq. 8 with Delta M = 0 gives
d lambda_i / dp = phi_i^T (dK/dp) phi_i for mass-normalised phi_i, so
d f_i / dp = phi_i^T (dK/dp) phi_i / (8 pi^2 f_i); dK/dp is the change of the joints'
linear stiffness per unit p. Gauss-Newton steps are taken in log p (stiffnesses span
decades) within seed 000's bounds [1e-5, 1.1] x the start value, each step at most a
factor 10, until the relative change of p is below ``tol``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from labjoint.errors import InputError, LabjointError
from labjoint.structure.assembly import Structure

BOUNDS = (1e-5, 1.1)
MAX_LOG_STEP = np.log(10.0)


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
        has = name in j.law.params or (name == "E_e_pa" and j.layer is not None)
        joints.append(j.with_parameter(name, value) if has else j)
    return structure.with_joints(tuple(joints))


def parameter_value(structure: Structure, name: str) -> float:
    for j in structure.joints:
        if name in j.law.params or (name == "E_e_pa" and j.layer is not None):
            return j.parameter(name)
    raise InputError(f"no joint has parameter '{name}'", field="update.parameter")


@dataclass(frozen=True)
class UpdateResult:
    """Stage-1 result: the parameter, the frequencies before and after, the history."""

    parameter: str
    initial: float
    value: float
    bounds: tuple[float, float]
    measured_hz: np.ndarray
    initial_hz: np.ndarray
    updated_hz: np.ndarray
    history: list[dict]
    structure: Structure

    def to_dict(self) -> dict:
        unit = "Pa" if self.parameter == "E_e_pa" else "SI"
        return {"parameters": {self.parameter: {"value": self.value, "initial": self.initial,
                                                "lower": self.bounds[0], "upper": self.bounds[1],
                                                "unit": unit}},
                "frequencies_hz": self.updated_hz.tolist(), "initial_frequencies_hz": self.initial_hz.tolist(),
                "measured_hz": self.measured_hz.tolist(),
                "objective": float(np.sum(((self.updated_hz - self.measured_hz) / self.measured_hz) ** 2)),
                "history": self.history}


def update_stiffness(structure: Structure, measured_hz: list[float] | np.ndarray, parameter: str | None = None,
                     max_iter: int = 50, tol: float = 1e-6) -> UpdateResult:
    """Eigen-sensitivity updating of one joint parameter (module docstring)."""
    f_test = np.asarray(measured_hz, float)
    if f_test.ndim != 1 or f_test.size == 0 or not np.all(np.isfinite(f_test) & (f_test > 0)):
        raise InputError("measured frequencies must be positive numbers", field="measured_hz")
    name = parameter or default_parameter(structure)
    p0 = parameter_value(structure, name)
    if not p0 > 0:
        raise InputError(f"start value must be > 0, got {p0:g}", field=name)
    lo, hi = BOUNDS[0] * p0, BOUNDS[1] * p0
    m = f_test.size
    history = []
    x = np.log(p0)
    s = structure
    f0 = None
    for it in range(max_iter + 1):
        p = float(np.exp(x))
        s = with_parameter(structure, name, p)
        K = s.stiffness()
        md = modes(s, m, K)
        f = md.frequencies_hz
        f0 = f if f0 is None else f0
        dp = 1e-6 * p
        dK = (with_parameter(structure, name, p + dp).stiffness() - K) / dp
        df_dp = np.einsum("ij,ik,kj->j", md.shapes, dK, md.shapes) / (8 * np.pi ** 2 * f)  # Eq. 8
        r = (f - f_test) / f_test
        J = df_dp * p / f_test                                   # d r / d log p
        history.append({"iteration": it, name: p, "frequencies_hz": f.tolist(),
                        "objective": float(r @ r)})
        if not (J @ J) > 0:
            raise LabjointError(f"the frequencies do not depend on {name}: cannot update it")
        step = float(np.clip(-(J @ r) / (J @ J), -MAX_LOG_STEP, MAX_LOG_STEP))
        x_new = float(np.clip(x + step, np.log(lo), np.log(hi)))
        if abs(x_new - x) < tol:
            break
        x = x_new
    else:
        raise LabjointError(f"stage-1 updating of {name} did not converge in {max_iter} "
                            f"iterations (last value {np.exp(x):.6g}, objective {history[-1]['objective']:.3g})")
    return UpdateResult(name, p0, float(np.exp(x)), (lo, hi), f_test, f0, f, history, s)
