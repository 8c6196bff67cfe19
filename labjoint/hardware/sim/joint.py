"""Hysteretic joint laws in numba, stepped by displacement increments (rate independent).

Laws as labjoint.vocabulary defines them. Every Jenkins-type element (the contact rings,
``coulomb``, the discretised Segalman ``iwan``) lives in one array: stiffness k_i, slip
displacement phi_i = f_i / k_i and slider position z_i, so the force of element i is
k_i (u - z_i) with -f_i s_- <= k_i (u - z_i) <= f_i s_+, where s_+ = w (1 + asym),
s_- = w (1 - asym) and w = exp(-E_d / E_w) is the wear factor. Smooth laws (Bouc-Wen,
Valanis, Richard-Abbott) are integrated in u with RK4 (or evaluated in closed form).

The ``seed002`` joint puts a viscoelastic shear layer (Kelvin-Voigt: k_l parallel to c_l)
in series with the hysteretic elements: with y the displacement the elements see, the
force through the layer k_l (u - y) + c_l (du/dt - dy/dt) equals the elements' force
F_c(y). Each step solves this linearly implicitly with the elements' elastic stiffness
K_c (an upper bound of their tangent), so it is stable for any c_l / dt.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from labjoint.hardware.sim.contact import Rings
from labjoint.hardware.sim.effects import JointSpec

BOUC_WEN, VALANIS, RICHARD_ABBOTT = 1, 2, 3
SMOOTH_CODES = {"bouc_wen": BOUC_WEN, "valanis": VALANIS, "richard_abbott": RICHARD_ABBOTT}
PARAM_ORDER = {"bouc_wen": ("k0", "alpha", "beta", "n"), "valanis": ("E0", "Et", "lam", "kappa"),
               "richard_abbott": ("ke", "kp", "F_y", "n")}
N_SMOOTH_STATE = 6
# eff array layout
K_LIN, K3, C_VISC, F0, M_IN, ASYM, INV_EW, HALF_GAP, LAYER_K, LAYER_C, LAYER_KC = range(11)
#: joint state: [u_eff of the previous call, dissipated energy E_d, layer y, element force F_c]
N_JOINT_STATE = 4


def segalman_elements(F_S: float, K_T: float, chi: float, beta: float, n: int = 200,
                      smallest: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """Discretise Segalman's 4-parameter Iwan density into Jenkins elements (k_i, f_i).

    rho(phi) = R phi^chi on (0, phi_max) plus S delta(phi - phi_max) (vocabulary ``iwan``);
    bins are geometric from ``smallest * phi_max`` to phi_max (plus the bin from 0).
    Per bin, k_i = int rho dphi and f_i = int rho phi dphi, so sum k_i = K_T and
    sum f_i = F_S exactly.
    """
    c = (chi + 1.0) / (chi + 2.0)
    phi_max = F_S * (1.0 + beta) / (K_T * (beta + c))
    R = F_S * (chi + 1.0) / (phi_max ** (chi + 2.0) * (beta + c))
    S = (F_S / phi_max) * (beta / (beta + c))
    edges = np.concatenate([[0.0], phi_max * smallest ** (1.0 - np.arange(n) / (n - 1))])
    k = R * np.diff(edges ** (chi + 1.0)) / (chi + 1.0)
    f = R * np.diff(edges ** (chi + 2.0)) / (chi + 2.0)
    if S > 0:
        k = np.append(k, S)
        f = np.append(f, S * phi_max)
    return k, f


@dataclass
class PackedJoint:
    """Arrays the numba kernels step; the first ``n_contact`` Jenkins elements are contact rings."""

    jk: np.ndarray
    jf: np.ndarray
    jphi: np.ndarray
    jz: np.ndarray
    n_contact: int
    sm_code: np.ndarray
    sm_par: np.ndarray
    sm_st: np.ndarray
    eff: np.ndarray

    def set_contact_slip_forces(self, slip_force: np.ndarray) -> None:
        """New ring thresholds (new normal force); slider positions are kept."""
        n = self.n_contact
        self.jf[:n] = slip_force
        self.jphi[:n] = slip_force / self.jk[:n]

    def reset(self) -> None:
        self.jz[:] = 0.0
        self.sm_st[:] = 0.0
        self.sm_st[:, 4] = 1.0  # Richard-Abbott starts on its virgin curve


def pack_joint(spec: JointSpec, rings: Rings | None,
               layer: tuple[float, float] | None = None) -> PackedJoint:
    """Arrays for the numba kernels from a parsed joint and (for ``contact``) its rings.

    ``layer`` = (k_l N/m, c_l Ns/m) of the series shear layer (needed when ``spec.layer``).
    """
    if spec.layer and layer is None:
        raise ValueError("the seed002 joint needs its shear layer (k_l, c_l)")
    ks: list[np.ndarray] = []
    fs: list[np.ndarray] = []
    smooth: list[tuple[str, dict[str, float]]] = []
    n_contact = 0
    if spec.has_contact:
        if rings is None:
            raise ValueError("the contact joint needs its rings")
        ks.append(rings.stiffness)
        fs.append(rings.slip_force)
        n_contact = len(rings.stiffness)
    elements = list(spec.hysteretic)
    if spec.family not in ("contact", "none"):
        elements.insert(0, (spec.family, spec.params))
    for name, p in elements:
        if name == "coulomb":
            ks.append(np.array([p["k"]]))
            fs.append(np.array([p["f_s"]]))
        elif name == "iwan":
            k, f = segalman_elements(p["F_S"], p["K_T"], p["chi"], p["beta"])
            ks.append(k)
            fs.append(f)
        else:
            smooth.append((name, p))
    jk = np.concatenate(ks) if ks else np.zeros(0)
    jf = np.concatenate(fs) if fs else np.zeros(0)
    sm_code = np.array([SMOOTH_CODES[n] for n, _ in smooth], dtype=np.int64)
    sm_par = np.array([[p[k] for k in PARAM_ORDER[n]] for n, p in smooth], dtype=float).reshape(len(smooth), 4)
    k_l, c_l = layer if spec.layer and layer is not None else (0.0, 0.0)
    k_c = float(np.sum(jk)) + float(sum(p[PARAM_ORDER[n][0]] for n, p in smooth))
    eff = np.array([spec.k_lin, spec.k3, spec.c, spec.f0, spec.inertia_m, spec.asym,
                    0.0 if math.isinf(spec.wear_e_w) else 1.0 / spec.wear_e_w, 0.5 * spec.gap,
                    float(k_l), float(c_l), k_c])
    packed = PackedJoint(jk=jk.astype(float), jf=jf.astype(float), jphi=(jf / jk).astype(float) if len(jk) else jf,
                         jz=np.zeros(len(jk)), n_contact=n_contact, sm_code=sm_code, sm_par=sm_par,
                         sm_st=np.zeros((len(smooth), N_SMOOTH_STATE)), eff=eff)
    packed.reset()
    return packed


@njit(cache=True, inline="always", fastmath=True)
def _jenkins(u, k, phi, z, w, asym):
    # branch-free clamp of each slider into [u - phi s_+, u + phi s_-]; dissipation f |dz|
    up = w * (1.0 + asym)
    dn = w * (1.0 - asym)
    force = 0.0
    de = 0.0
    for i in range(k.shape[0]):
        ki = k[i]
        p = phi[i]
        zi = z[i]
        a = u - p * up - zi
        b = zi - u - p * dn
        a = a if a > 0.0 else 0.0
        b = b if b > 0.0 else 0.0
        de += ki * p * (up * a + dn * b)
        zi += a - b
        z[i] = zi
        force += ki * (u - zi)
    return force, de


@njit(cache=True)
def _bw_rhs(z, s, k0, al, be, n):
    sg = 1.0 if z * s > 0.0 else (-1.0 if z * s < 0.0 else 0.0)
    return k0 - abs(z) ** n * (al * sg + be)


@njit(cache=True)
def _bouc_wen(st, par, du, w, asym):
    # classical law dz/du = k0 - |z|^n (alpha sgn(z du) + beta); wear and asym scale the
    # slip strength, i.e. alpha and beta by (w (1 +- asym))^-n
    z0 = st[0]
    if du == 0.0:
        return z0, 0.0
    k0, n = par[0], par[3]
    s = 1.0 if du > 0.0 else -1.0
    f = (w * (1.0 + asym * s)) ** (-n)
    al, be = par[1] * f, par[2] * f
    zsat = (k0 / (al + be)) ** (1.0 / n) if al + be > 0.0 else 1e12
    zsat = max(zsat, abs(z0))
    zr = min(abs(z0) + k0 * abs(du), zsat)
    lam = n * (abs(al) + abs(be)) * max(zr, 1e-300) ** (n - 1.0)
    m = 1 + int(min(4.0 * lam * abs(du), 399.0))
    h = du / m
    z = z0
    for _ in range(m):
        a1 = _bw_rhs(z, s, k0, al, be, n)
        a2 = _bw_rhs(z + 0.5 * h * a1, s, k0, al, be, n)
        a3 = _bw_rhs(z + 0.5 * h * a2, s, k0, al, be, n)
        a4 = _bw_rhs(z + h * a3, s, k0, al, be, n)
        z += h * (a1 + 2.0 * a2 + 2.0 * a3 + a4) / 6.0
        z = min(max(z, -zsat), zsat)
    st[0] = z
    return z, 0.5 * (z0 + z) * du - (z * z - z0 * z0) / (2.0 * k0)


@njit(cache=True)
def _val_rhs(u, f, s, e0, et, lam, kappa):
    d = (lam / e0) * s * (et * u - f)
    den = 1.0 + kappa * d
    if den < 1e-9:
        den = 1e-9
    return e0 * (1.0 + d) / den


@njit(cache=True)
def _val_stored(u, f, e0, et):
    if e0 > et:
        return 0.5 * et * u * u + (f - et * u) ** 2 / (2.0 * (e0 - et))
    return 0.5 * f * f / e0


@njit(cache=True)
def _valanis(st, par, u0, du, w, asym):
    f0 = st[0]
    if du == 0.0:
        return f0, 0.0
    e0, et, lam0, kappa = par[0], par[1], par[2], par[3]
    s = 1.0 if du > 0.0 else -1.0
    lam = lam0 / (w * (1.0 + asym * s))
    m = min(int(4.0 * lam * abs(du)) + 1, 400)
    h = du / m
    f = f0
    u = u0
    for _ in range(m):
        a1 = _val_rhs(u, f, s, e0, et, lam, kappa)
        a2 = _val_rhs(u + 0.5 * h, f + 0.5 * h * a1, s, e0, et, lam, kappa)
        a3 = _val_rhs(u + 0.5 * h, f + 0.5 * h * a2, s, e0, et, lam, kappa)
        a4 = _val_rhs(u + h, f + h * a3, s, e0, et, lam, kappa)
        f += h * (a1 + 2.0 * a2 + 2.0 * a3 + a4) / 6.0
        u += h
    st[0] = f
    de = 0.5 * (f0 + f) * du - (_val_stored(u0 + du, f, e0, et) - _val_stored(u0, f0, e0, et))
    return f, de


@njit(cache=True)
def ra_backbone(x, ke, kp, fy, n):
    """Richard-Abbott backbone g(x) (seed 000 Eq. 2 with stress -> force, strain -> displacement)."""
    d = ke - kp
    return d * x / (1.0 + abs(d * x / fy) ** n) ** (1.0 / n) + kp * x


@njit(cache=True)
def _ra_stored(u, f, ke, kp):
    if ke > kp:
        return (f - kp * u) ** 2 / (2.0 * (ke - kp)) + 0.5 * kp * u * u
    return 0.5 * f * f / ke


@njit(cache=True)
def _richard_abbott(st, par, u, du, w, asym):
    # st: force, u_r, F_r, direction, virgin, u_prev
    f_old = st[0]
    if du == 0.0:
        return f_old, 0.0
    ke, kp, fy, n = par[0], par[1], par[2], par[3]
    s = 1.0 if du > 0.0 else -1.0
    if st[3] != 0.0 and s != st[3]:
        st[1] = st[5]
        st[2] = f_old
        st[4] = 0.0
    st[3] = s
    if st[4] > 0.0:
        f = ra_backbone(u, ke, kp, fy * w * (1.0 + asym * s), n)
    else:
        # Masing branch; its height 2 F_y is the travel between the + and - slip
        # strengths F_y (1 + asym) + F_y (1 - asym), as in a parallel Iwan network.
        f = st[2] + 2.0 * ra_backbone(0.5 * (u - st[1]), ke, kp, fy * w, n)
    st[0] = f
    st[5] = u
    return f, 0.5 * (f_old + f) * du - (_ra_stored(u, f, ke, kp) - _ra_stored(u - du, f_old, ke, kp))


@njit(cache=True, inline="always")
def hysteretic_force(u, du, jk, jphi, jz, sm_code, sm_par, sm_st, w, asym):
    """Step every hysteretic element to displacement ``u`` (increment ``du``): (force, dissipated)."""
    force, de = _jenkins(u, jk, jphi, jz, w, asym)
    for e in range(sm_code.shape[0]):
        c = sm_code[e]
        if c == 1:
            f, d = _bouc_wen(sm_st[e], sm_par[e], du, w, asym)
        elif c == 2:
            f, d = _valanis(sm_st[e], sm_par[e], u - du, du, w, asym)
        else:
            f, d = _richard_abbott(sm_st[e], sm_par[e], u, du, w, asym)
        force += f
        de += d
    return force, de


@njit(cache=True, inline="always")
def backlash(u, half_gap):
    """u_eff = sgn(u) max(|u| - g/2, 0) (vocabulary ``backlash``)."""
    if u > half_gap:
        return u - half_gap
    if u < -half_gap:
        return u + half_gap
    return 0.0


@njit(cache=True, inline="always")
def joint_force(u, v, dt, state, jk, jphi, jz, sm_code, sm_par, sm_st, eff):
    """Force the joint exerts (hysteretic + elastic + viscous, without the held preload F0).

    ``state`` (N_JOINT_STATE): [u_eff of the previous call, dissipated energy E_d, layer
    y, element force F_c]; all are updated. ``dt``: time since the previous call.
    """
    hg = eff[HALF_GAP]
    ue = backlash(u, hg)
    ve = v if (u > hg or u < -hg) else 0.0
    w = math.exp(-state[1] * eff[INV_EW]) if eff[INV_EW] > 0.0 else 1.0
    kl = eff[LAYER_K]
    if kl > 0.0:
        # series shear layer (module doc): one linearly implicit step for y
        cl = eff[LAYER_C]
        y = state[2]
        dy = (cl * ve + kl * (ue - y) - state[3]) / (cl / dt + kl + eff[LAYER_KC])
        fh, de = hysteretic_force(y + dy, dy, jk, jphi, jz, sm_code, sm_par, sm_st, w, eff[ASYM])
        state[2] = y + dy
        state[3] = fh
    else:
        fh, de = hysteretic_force(ue, ue - state[0], jk, jphi, jz, sm_code, sm_par, sm_st, w, eff[ASYM])
    state[0] = ue
    state[1] = max(state[1] + de, 0.0)
    return fh + eff[K_LIN] * ue + eff[K3] * ue * ue * ue + eff[C_VISC] * ve


@njit(cache=True)
def _prescribed(u, dt, state, jk, jphi, jz, sm_code, sm_par, sm_st, eff, out):
    for i in range(u.shape[0]):
        if i == 0:
            v = 0.0
        else:
            v = (u[i] - u[i - 1]) / dt
        out[i] = joint_force(u[i], v, dt, state, jk, jphi, jz, sm_code, sm_par, sm_st, eff) + eff[F0]


def prescribed_displacement(spec: JointSpec, u: np.ndarray, dt: float = 1e-5,
                            rings: Rings | None = None,
                            layer: tuple[float, float] | None = None) -> np.ndarray:
    """Joint force (N) for a prescribed relative displacement history ``u`` (m) from rest.

    Uses the same laws as the simulated rig (without inertia and channel delay, which
    belong to the measurement path); velocity for ``viscous`` by backward difference.
    """
    packed = pack_joint(spec, rings, layer)
    u = np.ascontiguousarray(u, dtype=float)
    out = np.empty_like(u)
    _prescribed(u, float(dt), np.zeros(N_JOINT_STATE), packed.jk, packed.jphi, packed.jz, packed.sm_code,
                packed.sm_par, packed.sm_st, packed.eff, out)
    return out
