"""An independent generator of step-sine FRFs (issue 32's checks, written for the tests):
its own Euler-Bernoulli finite elements of seed 000's two pipes joined at x = 0.587 m
(clamped at x = 0, shaken at the free end), its own joint laws acting on the relative
rotation of the two sides, its own multi-harmonic balance (AFT, Newton with a
finite-difference Jacobian of the joint's coefficients) and its own noise. Nothing of
labjoint's structure, models or simulator is used; FrfSet is only the file format.

The joint: the transverse displacement is shared, the rotations of the two sides
theta_a, theta_b are separate DOFs joined by M(theta), theta = theta_b - theta_a:
- "null": k_r theta;
- "iwan": (1 - s) k_r theta + a parallel population of Jenkins elements (stiffness s k_r
  in total, slip moments spread from 0 up to ``m_slip``: micro-slip), Masing steady state;
- "cubic": k_r theta + k3 theta^3;
- "contact": k_r theta + k_c max(theta, 0) (one side closes: even harmonics).
"""

from __future__ import annotations

import numpy as np

E, RHO, OD, WALL = 215e9, 7800.0, 0.114, 0.0038
L_A, L_B, N_A, N_B = 0.587, 1.080, 8, 14
K_R = 4.0e5            # N m/rad: mode 1 near 32 Hz
ZETA = 0.005
SAMPLES = 64


def section() -> tuple[float, float]:
    ri = OD / 2 - WALL
    return np.pi * ((OD / 2) ** 2 - ri ** 2), np.pi / 4 * ((OD / 2) ** 4 - ri ** 4)


def beam(k_r: float = K_R):
    """(M, K with the joint's linear stiffness, K without it, selector of theta, force
    vector at the free end, sensor rows: near the joint on the long pipe and the free end)."""
    A, I = section()
    # nodes: 0..N_A on pipe a; node N_A + 1 is the same point on pipe b (own rotation)
    n_nodes = N_A + 1 + N_B + 1
    # DOF map: every node has (w, theta); the joint's b-side node shares w with node N_A
    w_of = list(range(n_nodes))
    dofs = {}
    idx = 0
    for i in range(n_nodes):
        if i == N_A + 1:
            dofs[(i, 0)] = dofs[(N_A, 0)]
        else:
            dofs[(i, 0)] = idx
            idx += 1
        dofs[(i, 1)] = idx
        idx += 1
    n = idx
    M, K = np.zeros((n, n)), np.zeros((n, n))
    elems = [(i, i + 1, L_A / N_A) for i in range(N_A)] + \
            [(N_A + 1 + i, N_A + 2 + i, L_B / N_B) for i in range(N_B)]
    for a, b, h in elems:
        ke = E * I / h ** 3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                                        [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
        me = RHO * A * h / 420 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                            [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
        d = [dofs[(a, 0)], dofs[(a, 1)], dofs[(b, 0)], dofs[(b, 1)]]
        K[np.ix_(d, d)] += ke
        M[np.ix_(d, d)] += me
    keep = [i for i in range(n) if i not in (dofs[(0, 0)], dofs[(0, 1)])]   # clamped at x = 0
    M, K = M[np.ix_(keep, keep)], K[np.ix_(keep, keep)]
    pos = {d: keep.index(d) for d in keep}
    s = np.zeros(len(keep))
    s[pos[dofs[(N_A + 1, 1)]]] += 1.0
    s[pos[dofs[(N_A, 1)]]] -= 1.0
    Kj = K + k_r * np.outer(s, s)
    f = np.zeros(len(keep))
    f[pos[dofs[(n_nodes - 1, 0)]]] = 1.0
    near = N_A + 1 + 1                                    # 0.587 + 0.077 m on pipe b
    rows = np.zeros((2, len(keep)))
    rows[0, pos[dofs[(near, 0)]]] = 1.0
    rows[1, pos[dofs[(n_nodes - 1, 0)]]] = 1.0
    return M, Kj, K, s, f, rows, (L_A + L_B / N_B, L_A + L_B)


def modal_damping(M, K, zeta=ZETA):
    L = np.linalg.cholesky(M)
    ev, vec = np.linalg.eigh(np.linalg.solve(L, np.linalg.solve(L, K).T))
    phi = np.linalg.solve(L.T, vec)                       # mass-normalised
    w = np.sqrt(ev)
    Mp = M @ phi
    return (Mp * (2 * zeta * w)) @ Mp.T, w / (2 * np.pi)


def law(kind: str, theta: np.ndarray, k_r: float, p: dict) -> np.ndarray:
    """Joint moment over one period (theta sampled uniformly, steady state)."""
    if kind == "null":
        return k_r * theta
    if kind == "cubic":
        return k_r * theta + p["k3"] * theta ** 3
    if kind == "contact":
        return k_r * theta + p["k_c"] * np.maximum(theta, 0.0)
    # Iwan: Jenkins elements with slip moments m_i, each of stiffness ks / n, Masing steady state
    s, m_slip, n_el = p["share"], p["m_slip"], 40
    ks = s * k_r / n_el
    m_i = m_slip * (np.arange(n_el) + 0.5) / n_el
    i0 = int(np.argmax(theta))
    th = np.roll(theta, -i0)
    z = np.clip(ks * th[0], -m_i, m_i)                    # loaded from rest to the top
    out = np.empty(th.size)
    prev = th[0]
    for _ in range(2):                                    # two periods: the second is steady
        for k in range(th.size):
            z = np.clip(z + ks * (th[k] - prev), -m_i, m_i)
            prev = th[k]
            out[k] = z.sum()
    return (1 - s) * k_r * theta + np.roll(out, i0)


class HBM:
    """Multi-harmonic balance, AFT on the joint coordinate (module docstring)."""

    def __init__(self, kind: str, p: dict, H: int = 3, k_r: float = K_R):
        self.M, _, self.K0, self.s, self.f, self.rows, self.x_sensors = beam(k_r)
        self.C, self.fn = modal_damping(self.M, self.K0 + k_r * np.outer(self.s, self.s))
        self.kind, self.p, self.H, self.k_r = kind, p, H, k_r
        t = 2 * np.pi * np.arange(SAMPLES) / SAMPLES
        cols = [np.ones(SAMPLES)]
        for h in range(1, H + 1):
            cols += [np.cos(h * t), np.sin(h * t)]
        self.E = np.array(cols).T                         # (N, 2H+1)
        self.P = np.linalg.pinv(self.E)

    def residual(self, X: np.ndarray, w: float, F: float) -> np.ndarray:
        n, H = self.M.shape[0], self.H
        X = X.reshape(2 * H + 1, n)
        R = np.zeros_like(X)
        R[0] = self.K0 @ X[0]
        for h in range(1, H + 1):
            c, s = X[2 * h - 1], X[2 * h]
            A = self.K0 - (h * w) ** 2 * self.M
            R[2 * h - 1] = A @ c + h * w * self.C @ s
            R[2 * h] = A @ s - h * w * self.C @ c
        R[1] -= F * self.f
        q = self.E @ (X @ self.s)
        g = self.P @ law(self.kind, q, self.k_r, self.p)
        return (R + np.outer(g, self.s)).ravel()

    def solve(self, w: float, F: float, X0: np.ndarray | None) -> np.ndarray:
        n, m = self.M.shape[0], 2 * self.H + 1
        if X0 is None:
            Kl = self.K0 + self.k_r * np.outer(self.s, self.s)
            Z = Kl - w * w * self.M + 1j * w * self.C
            x = np.linalg.solve(Z, F * self.f)
            X0 = np.zeros((m, n))
            X0[1], X0[2] = x.real, -x.imag
            X0 = X0.ravel()
        X = X0.copy()
        scale = F * np.linalg.norm(self.f)
        R = self.residual(X, w, F)
        for _ in range(60):
            r = np.linalg.norm(R)
            if r < 1e-7 * scale:
                return X
            dX = -np.linalg.solve(self._jacobian(X, w, F, R), R)
            lam = 1.0
            while True:                                   # backtracking
                Rn = self.residual(X + lam * dX, w, F)
                if np.linalg.norm(Rn) < r or lam < 1e-3:
                    break
                lam /= 2
            X, R = X + lam * dX, Rn
        raise RuntimeError(f"independent HBM did not converge at {w / 2 / np.pi:.3f} Hz")

    def _jacobian(self, X, w, F, R):
        n, H, m = self.M.shape[0], self.H, 2 * self.H + 1
        J = np.zeros((m * n, m * n))
        J[:n, :n] = self.K0
        for h in range(1, H + 1):
            c, s = slice((2 * h - 1) * n, 2 * h * n), slice(2 * h * n, (2 * h + 1) * n)
            A = self.K0 - (h * w) ** 2 * self.M
            J[c, c], J[s, s], J[c, s], J[s, c] = A, A, h * w * self.C, -h * w * self.C
        Q = X.reshape(m, n) @ self.s
        g0 = self.P @ law(self.kind, self.E @ Q, self.k_r, self.p)
        dG = np.zeros((m, m))
        eps = 1e-7 * max(np.abs(Q).max(), 1e-12)
        for l in range(m):
            Qp = Q.copy()
            Qp[l] += eps
            dG[:, l] = (self.P @ law(self.kind, self.E @ Qp, self.k_r, self.p) - g0) / eps
        return J + np.kron(dG, np.outer(self.s, self.s))

    def step_sine(self, freqs, levels, noise=0.005, floor=1e-4, seed=0):
        """(frequencies, levels, response (n, 2 sensors, H) acceleration phasors, std)."""
        rng = np.random.default_rng(seed)
        fr, lv, resp = [], [], []
        n, m = self.M.shape[0], 2 * self.H + 1
        for F in levels:
            X = None
            for f in freqs:
                w = 2 * np.pi * f
                X = self.solve(w, F, X)
                Y = X.reshape(m, n) @ self.rows.T            # (2H+1, sensors)
                h = np.arange(1, self.H + 1)
                ph = (Y[1::2] - 1j * Y[2::2]) * -(h[:, None] * w) ** 2
                fr.append(f)
                lv.append(F)
                resp.append(ph.T)
        r = np.array(resp)
        std = noise * np.abs(r[:, :, :1]) + floor + np.zeros(r.shape)
        r = r + std * (rng.standard_normal(r.shape) + 1j * rng.standard_normal(r.shape)) / np.sqrt(2)
        return np.array(fr), np.array(lv), r, std
