"""The shaker identified together with the linear structure from a low-level test
(issue 29 item 3), with or without a force sensor.

Data: FRFs per generator volt at the frequencies f of a linear test: each response
sensor's Y_s / U in its own quantity (displacement, velocity or acceleration), the drive
point one of them, and F / U when a force is measured. The structure is its modes seen
from the drive point (:class:`LinearModes`):

    X_s / F = sum_j rho_sj / (m_j (w_j^2 - w^2 + 2 i zeta_j w_j w))                (M1)

(m_j: mode j's modal mass at the drive point, kg; rho_sj: sensor s's participation
relative to the drive point, 1 there; real modes: proportional damping; a 1-DOF
structure is one mode with m_1 = m), and
the model per volt is Y_s / U = (i w)^d_s (X_s / F) (F / U) with F / U from
:mod:`labjoint.models.shaker` (S3).

What a test determines (stated, then checked for the case at hand before the fit):

- **force measured**: X_s / F gives the structure and F / U with X_d / F the shaker, all
  of it but the amplifier gain G (it enters only as Bl G and Bl / G): G is given
  (``amplifier_gain_v_per_v``, default 1).
- **voltage and response only**: the armature (m_a, k_a, c_a) moves with the drive point
  and merges with the structure's modal mass, stiffness and damping there: never
  identifiable, refused at once unless given. The coil enters only as Bl G / R (the
  blocked force per volt) times the structure's compliance 1 / m_j, Bl^2 / R (the
  back-EMF's viscous damping, beside the structure's own) and L / R (a lag): two of Bl,
  R and the structure's scale (``mode1.mass_kg``, from a model or a weighed mass) must
  be given, else the first of Bl, R is refused by name. (With exactly proportional
  damping and noise-free data the split of damping between the coil and the structure
  shows through L; a lab's structure is not that exact, so this is not relied on.) L
  then follows from the coil's lag when its corner R / (2 pi L) is within reach of the
  band. The rank of the sensitivities at the start is checked after these rules
  (columns scaled, relative singular value below ``RANK_TOL``): a parameter in their
  null space is refused by name, "shaker parameter X not identifiable: give it", with
  those it trades off with.

Fit: least squares on the relative complex misfit of every FRF line (log parameters for
the positive ones), from a start of the structure's modes by a linear least squares on
the residues at fitted poles (variable projection) of the per-newton FRFs, measured or
rebuilt from the start shaker (S4). Standard errors from the Jacobian at the solution.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np
from scipy.optimize import least_squares

from labjoint.errors import InputError
from labjoint.models.shaker import (ARMATURE, COIL, SYMBOLS, Shaker, checked_values, force_from_motion,
                                   force_per_volt, shaker_from_force)

RANK_TOL = 1e-6
ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}
#: starts of the free shaker parameters without a force (a modal shaker's order of magnitude)
NOMINAL = {"force_factor_n_per_a": 10.0, "coil_resistance_ohm": 4.0, "coil_inductance_h": 1e-3,
           "armature_mass_kg": 0.05, "suspension_stiffness_n_per_m": 1e3, "suspension_damping_ns_per_m": 5.0}


@dataclass(frozen=True)
class LinearModes:
    """A linear structure seen from its drive point (M1)."""

    frequencies_hz: tuple[float, ...]
    damping_ratios: tuple[float, ...]
    masses_kg: tuple[float, ...]
    participation: dict[str, tuple[float, ...]]
    drive: str

    def receptance(self, frequencies_hz: Any, sensor: str) -> np.ndarray:
        """X_s / F (m/N)."""
        w = 2 * np.pi * np.asarray(frequencies_hz, float)
        out = np.zeros(w.shape, complex)
        rho = self.participation.get(sensor) if sensor != self.drive else (1.0,) * len(self.masses_kg)
        if rho is None:
            raise InputError(f"no sensor {sensor!r}; sensors: {sorted([self.drive, *self.participation])}",
                             field="sensor")
        for fj, zj, mj, rj in zip(self.frequencies_hz, self.damping_ratios, self.masses_kg, rho):
            wj = 2 * np.pi * fj
            out += rj / (mj * (wj * wj - w * w + 2j * zj * wj * w))
        return out


@dataclass(frozen=True)
class ShakerFit:
    """The identified shaker and structure; ``identified``/``given``: parameter names."""

    shaker: Shaker
    structure: LinearModes
    quantities: dict[str, str]
    identified: tuple[str, ...]
    given: tuple[str, ...]
    stderr: dict[str, float] = field(default_factory=dict)
    misfit: float = float("nan")
    force_measured: bool = False

    def per_newton(self, frequencies_hz: Any) -> dict[str, np.ndarray]:
        """Each sensor's FRF per newton on the structure, in its own quantity."""
        iw = 2j * np.pi * np.asarray(frequencies_hz, float)
        return {s: iw ** ORDER[q] * self.structure.receptance(frequencies_hz, s) for s, q in self.quantities.items()}

    def per_volt(self, frequencies_hz: Any) -> dict[str, np.ndarray]:
        """Each sensor's FRF per generator volt in its quantity, and ``force`` (N/V; S3)."""
        fu = force_per_volt(self.shaker, frequencies_hz, self.structure.receptance(frequencies_hz, self.structure.drive))
        out = {s: h * fu for s, h in self.per_newton(frequencies_hz).items()}
        out["force"] = fu
        return out

    def parameters(self) -> dict[str, dict[str, Any]]:
        """{name: {value, stderr (None if given), given, flag}}: shaker fields and the modes'."""
        vals = {f"shaker.{k}": v for k, v in self.shaker.to_dict().items()}
        vals.update(_structure_values(self.structure))
        out = {}
        for k, v in vals.items():
            se = self.stderr.get(k)
            row: dict[str, Any] = {"value": v, "stderr": se, "given": k in self.given}
            if se is not None and not se <= abs(v):
                row["flag"] = "stderr exceeds the value: not determined by this test"
            out[k] = row
        return out


def _structure_values(s: LinearModes) -> dict[str, float]:
    out = {}
    for j, (f, z, m) in enumerate(zip(s.frequencies_hz, s.damping_ratios, s.masses_kg), 1):
        out.update({f"mode{j}.frequency_hz": f, f"mode{j}.damping_ratio": z, f"mode{j}.mass_kg": m})
        for sen, rho in s.participation.items():
            out[f"mode{j}.{sen}"] = rho[j - 1]
    return out


def _modes_fit(f: np.ndarray, h: Mapping[str, np.ndarray], drive: str, n_modes: int,
               starts_hz: Any) -> LinearModes:
    """Modes (M1) of per-newton receptances: poles by least squares, real residues by linear
    least squares at each trial (variable projection)."""
    w = 2 * np.pi * f
    sensors = [drive, *[s for s in h if s != drive]]
    if starts_hz is None:
        a = np.abs(h[drive])
        pk = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
        pk = pk[np.argsort(a[pk])[::-1][:n_modes]]
        if pk.size < n_modes:
            raise InputError(f"{pk.size} peaks in the drive point's FRF for {n_modes} modes: give the "
                             "modes' frequencies", field="modes")
        starts_hz = np.sort(f[pk])
    fs0 = np.asarray(starts_hz, float)

    def basis(x: np.ndarray) -> np.ndarray:
        wj, zj = 2 * np.pi * np.exp(x[:n_modes]), np.exp(x[n_modes:])
        return 1.0 / (wj[None] ** 2 - w[:, None] ** 2 + 2j * zj[None] * wj[None] * w[:, None])

    def solve(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        B = basis(x)
        res, A = [], []
        for s in sensors:
            wt = 1.0 / np.maximum(np.abs(h[s]), 1e-300)
            Bw = B * wt[:, None]
            M = np.vstack([Bw.real, Bw.imag])
            y = np.concatenate([(h[s] * wt).real, (h[s] * wt).imag])
            a = np.linalg.lstsq(M, y, rcond=None)[0]
            A.append(a)
            res.append(M @ a - y)
        return np.concatenate(res), np.array(A)

    x0 = np.r_[np.log(fs0), np.log(np.full(n_modes, 0.02))]
    sol = least_squares(lambda x: solve(x)[0], x0, x_scale=1.0, method="lm")
    A = solve(sol.x)[1]
    if not np.all(A[0] > 0):
        j = int(np.flatnonzero(~(A[0] > 0))[0]) + 1
        raise InputError(f"mode {j}'s drive-point residue is not positive: the drive sensor is not at "
                         "the drive point, or its sign is inverted", field="drive")
    rho = {s: tuple(float(v) for v in A[i] / A[0]) for i, s in enumerate(sensors) if s != drive}
    return LinearModes(tuple(float(v) for v in np.exp(sol.x[:n_modes])),
                       tuple(float(v) for v in np.exp(sol.x[n_modes:])),
                       tuple(float(v) for v in 1.0 / A[0]), rho, drive)


def _pack(shaker: Shaker, modes: LinearModes, free: list[str]) -> np.ndarray:
    vals = {f"shaker.{k}": v for k, v in shaker.to_dict().items()}
    vals.update(_structure_values(modes))
    return np.array([vals[n] if _signed(n, modes) else np.log(max(vals[n], 1e-300)) for n in free])


def _signed(name: str, modes: LinearModes) -> bool:
    return name.split(".", 1)[1] in modes.participation


def _unpack(x: np.ndarray, free: list[str], shaker: Shaker, modes: LinearModes) -> tuple[Shaker, LinearModes]:
    sv = shaker.to_dict()
    f, z, m = list(modes.frequencies_hz), list(modes.damping_ratios), list(modes.masses_kg)
    rho = {s: list(r) for s, r in modes.participation.items()}
    for n, v in zip(free, x):
        head, tail = n.split(".", 1)
        val = float(v) if _signed(n, modes) else float(np.exp(v))
        if head == "shaker":
            sv[tail] = val
        else:
            j = int(head[4:]) - 1
            {"frequency_hz": f, "damping_ratio": z, "mass_kg": m}.get(tail, rho.get(tail, []))[j] = val
    return (Shaker(**sv), LinearModes(tuple(f), tuple(z), tuple(m), {s: tuple(r) for s, r in rho.items()},
                                      modes.drive))


def identify(frequencies_hz: Any, responses_per_volt: Mapping[str, Any], drive: str, *,
             quantities: Mapping[str, str] | None = None, force_per_volt_measured: Any = None,
             given: Mapping[str, float] | None = None, n_modes: int = 1,
             modes_hz: Any = None) -> ShakerFit:
    """The shaker and the structure's modes from a low-level test (module doc).

    ``given``: shaker fields (the ``[shaker]`` table, :func:`labjoint.models.shaker.shaker_table`)
    and structure parameters (``mode1.mass_kg``, ...) held at their values."""
    f = np.asarray(frequencies_hz, float)
    if f.ndim != 1 or f.size < 4 or not np.all(np.isfinite(f) & (f > 0)):
        raise InputError("needs at least 4 positive frequencies", field="frequencies_hz")
    if drive not in responses_per_volt:
        raise InputError(f"the drive point {drive!r} is not among the responses "
                         f"{sorted(responses_per_volt)}", field="drive")
    q = {s: (quantities or {}).get(s, "displacement") for s in responses_per_volt}
    for s, qq in q.items():
        if qq not in ORDER:
            raise InputError(f"quantity {qq!r} is not one of {sorted(ORDER)}", field=f"quantities.{s}")
    iw = 2j * np.pi * f
    x = {}
    for s, y in responses_per_volt.items():
        y = np.asarray(y, complex)
        if y.shape != f.shape or not np.all(np.isfinite(y)) or not np.any(y != 0):
            raise InputError("must be finite, not all zero, one value per frequency", field=f"responses.{s}")
        x[s] = y / iw ** ORDER[q[s]]
    given = dict(given or {})
    shaker_given = checked_values({k: v for k, v in given.items() if k in SYMBOLS})
    struct_given = {k: float(v) for k, v in given.items() if k not in SYMBOLS}
    has_force = force_per_volt_measured is not None
    if has_force:
        fu = np.asarray(force_per_volt_measured, complex)
        if fu.shape != f.shape or not np.all(np.isfinite(fu)) or np.any(fu == 0):
            raise InputError("must be finite and non-zero, one value per frequency", field="force")
        start = replace(shaker_from_force(f, fu, -(2 * np.pi * f) ** 2 * x[drive] / fu,
                                          shaker_given.get("amplifier_gain_v_per_v", 1.0)),
                        **shaker_given)
        free_shaker = [k for k in SYMBOLS if k != "amplifier_gain_v_per_v" and k not in shaker_given]
    else:
        fu = None
        require_voltage_only(shaker_given, struct_given)
        start = Shaker(**{**NOMINAL, **shaker_given})
        free_shaker = [k for k in COIL if k not in shaker_given]
    if not has_force:
        start = _scan_start(f, x, drive, start, free_shaker, int(n_modes), modes_hz, q)
    per_newton = {s: v / (fu if has_force else force_from_motion(start, f, 1.0, x[drive])) for s, v in x.items()}
    modes = _modes_fit(f, per_newton, drive, int(n_modes), modes_hz)
    names = list(_structure_values(modes))
    unknown = sorted(set(struct_given) - set(names))
    if unknown:
        raise InputError(f"unknown structure parameter; known: {', '.join(names)}", field=unknown[0])
    if struct_given:
        _, modes = _unpack(np.array([v if _signed(k, modes) else np.log(v) for k, v in struct_given.items()]),
                           list(struct_given), start, modes)
    free = [f"shaker.{k}" for k in free_shaker] + [n for n in names if n not in struct_given]
    data = [(s, y) for s, y in x.items()] + ([("force", fu)] if has_force else [])

    def residual(p: np.ndarray) -> np.ndarray:
        sh, md = _unpack(p, free, start, modes)
        fit = ShakerFit(sh, md, q, (), ())
        pv = fit.per_volt(f)
        r = []
        for s, y in data:
            model = pv["force"] if s == "force" else pv[s] / iw ** ORDER[q[s]]
            e = (model - y) / np.abs(y)
            r += [e.real, e.imag]
        return np.concatenate(r)

    x0 = _pack(start, modes, free)
    _require_identifiable(residual, x0, free, has_force)
    # with a force the shaker is the closed form's (exact, whatever the structure's modes);
    # the least squares then moves the structure only
    moving = [n for n in free if not (has_force and n.startswith("shaker."))]
    idx = [free.index(n) for n in moving]

    def partial(p: np.ndarray) -> np.ndarray:
        full = x0.copy()
        full[idx] = p
        return residual(full)

    sol = least_squares(partial, x0[idx], method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12)
    xs = x0.copy()
    xs[idx] = sol.x
    sh, md = _unpack(xs, free, start, modes)
    fun = residual(xs)
    jac = _jacobian(residual, xs)
    dof = max(fun.size - len(free), 1)
    s2 = float(fun @ fun) / dof
    try:
        sd = np.sqrt(np.clip(np.diag(np.linalg.inv(jac.T @ jac)) * s2, 0, None))
    except np.linalg.LinAlgError:
        sd = np.full(len(free), np.nan)
    vals = {f"shaker.{k}": v for k, v in sh.to_dict().items()}
    vals.update(_structure_values(md))
    stderr = {n: float(sd[i] if _signed(n, md) else vals[n] * sd[i]) for i, n in enumerate(free)}
    given_names = tuple([f"shaker.{k}" for k in shaker_given] + list(struct_given)
                        + ([] if "amplifier_gain_v_per_v" in shaker_given
                           else ["shaker.amplifier_gain_v_per_v"]))      # G: 1 unless given
    return ShakerFit(sh, md, q, tuple(free), given_names, stderr,
                     float(np.sqrt(np.mean(fun ** 2) * 2)), has_force)


def require_voltage_only(shaker_given: Mapping[str, float], struct_given: Mapping[str, Any]) -> str | None:
    """The rules of a test without a force (module doc), for this test and for the modal
    model's shaker path (:mod:`labjoint.structure.nlmode_shaker`): the armature given,
    else refused by name; two of Bl, R and ``mode1.mass_kg`` given, else the first of Bl,
    R missing refused by name. Returns the one of the three the response determines
    (None when all three are given)."""
    missing = [k for k in ARMATURE if k not in shaker_given]
    if missing:
        raise InputError(f"shaker parameter {missing[0]} ({SYMBOLS[missing[0]]}) not identifiable "
                         "without a force: the armature moves with the drive point and merges "
                         f"with the structure there; give it ([shaker] {missing[0]} = ...)",
                         field=f"shaker.{missing[0]}")
    scale = [k for k in ("force_factor_n_per_a", "coil_resistance_ohm") if k in shaker_given]
    if len(scale) + ("mode1.mass_kg" in struct_given) < 2:
        k = next(k for k in ("force_factor_n_per_a", "coil_resistance_ohm") if k not in shaker_given)
        raise InputError(f"shaker parameter {k} ({SYMBOLS[k]}) not identifiable without a force: the "
                         "record sees Bl G / R and Bl^2 / R only relative to the structure's modal "
                         "mass; give it ([shaker] " + k + " = ...; two of Bl, R and mode1.mass_kg)",
                         field=f"shaker.{k}")
    free = [f"shaker.{k}" for k in ("force_factor_n_per_a", "coil_resistance_ohm") if k not in shaker_given]
    free += [] if "mode1.mass_kg" in struct_given else ["mode1.mass_kg"]
    return free[0] if free else None


def _scan_start(f: np.ndarray, x: Mapping[str, np.ndarray], drive: str, start: Shaker, free: list[str],
                n_modes: int, modes_hz: Any, q: Mapping[str, str]) -> Shaker:
    """The free coil parameters' start: each in turn over a log grid (x 1/30 .. 30), the
    structure's modes refitted to the force rebuilt with it (S4), the best per-volt misfit
    kept (two passes)."""
    f_arr = np.asarray(f)

    def cost(sh: Shaker) -> float:
        try:
            fs_ = force_from_motion(sh, f_arr, 1.0, x[drive])
            md = _modes_fit(f_arr, {s: v / fs_ for s, v in x.items()}, drive, n_modes, modes_hz)
            pv = ShakerFit(sh, md, dict(q), (), ()).per_volt(f_arr)
        except (InputError, np.linalg.LinAlgError, ValueError):
            return np.inf
        iw = 2j * np.pi * f_arr
        return float(sum(np.sum(np.abs(pv[s] / iw ** ORDER[q[s]] / v - 1) ** 2) for s, v in x.items()))

    best = start
    for _ in range(2):
        for k in free:
            cands = [replace(best, **{k: getattr(best, k) * g}) for g in np.geomspace(1 / 30, 30, 13)]
            best = min(cands, key=cost)
    return best


def _jacobian(residual: Any, x0: np.ndarray) -> np.ndarray:
    r0 = residual(x0)
    J = np.empty((r0.size, x0.size))
    for i in range(x0.size):
        h = 1e-6 * max(1.0, abs(x0[i]))
        xp, xm = x0.copy(), x0.copy()
        xp[i] += h
        xm[i] -= h
        J[:, i] = (residual(xp) - residual(xm)) / (2 * h)
    return J


def _require_identifiable(residual: Any, x0: np.ndarray, free: list[str], has_force: bool) -> None:
    """Refuse, by name, a parameter in the null space of the scaled sensitivities."""
    J = _jacobian(residual, x0)
    norm = np.linalg.norm(J, axis=0)
    dead = [free[i] for i in np.flatnonzero(norm == 0)]
    _, sv, vt = np.linalg.svd(J / np.where(norm > 0, norm, 1.0), full_matrices=False)
    null = vt[sv < RANK_TOL * sv[0]]
    if not dead and not null.size:
        return
    raw = np.abs(null / np.where(norm > 0, norm, 1.0)).max(axis=0) if null.size else np.zeros(len(free))
    v = raw / raw.max() if raw.max() > 0 else raw                    # in log parameters: scale-free
    order = np.argsort(v)[::-1]
    involved = [free[i] for i in order if v[i] > 0.1] + dead
    pick = next((n for n in involved if n.startswith("shaker.")), involved[0])
    others = [n for n in involved if n != pick]
    name = pick.split(".", 1)[1]
    what = f"shaker parameter {name} ({SYMBOLS[name]})" if pick.startswith("shaker.") else f"parameter {pick}"
    raise InputError(f"{what} not identifiable from this test ({'with' if has_force else 'without'} a "
                     f"force){': it trades off with ' + ', '.join(others) if others else ''}; give it"
                     + (f" ([shaker] {name} = ...)" if pick.startswith("shaker.") else ""), field=pick)
