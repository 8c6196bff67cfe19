"""Time integration of the structural rig: modal coordinates, shaker coil, thread sliders.

Per step dt (symplectic Euler on the modes, stable for omega dt < 2, with the velocity at
the step's time taken as the half-step velocity plus half a step of the last acceleration,
so that damping, back-EMF and outputs are second order in dt): generator voltage
V = A sin(phase) + offset; coil current by the trapezoidal rule (stable at any step),
L di/dt = G V - R i - Bl v_drive; drive-point force Bl i - c_s v_drive (armature mass and
suspension stiffness are in the modal model); each thread's tangential slip
u = r (rotation of the coupling - rotation of the pipe) drives the Iwan sliders, and the
difference between the hysteretic force and the sticking spring already in the modes
(plus c du/dt) acts as a moment r F on the modes. The stinger force (what the force
sensor reads) is the drive-point force minus the armature's inertia and suspension.
"""

from __future__ import annotations

import math

from numba import njit

from labjoint.hardware.sim.structure_iwan import iwan_step

# par: A (half Vpp), offset, omega, on, G, R, L, Bl, c_s, k_s, m_a
# state: phase, current, previous coil input G V - Bl v
# out rows
FORCE, V_GEN, V_AMP, CURRENT, U0, F0, U1, F1, ACC = range(9)
# Richard-Abbott state columns: u previous, u and F at the last reversal, |u| max, direction,
# F previous, on the backbone (1) or a Masing branch (0)
N_RA_STATE = 7


@njit(cache=True, inline="always")
def _backbone(x, k0, kp, f0, n):
    return k0 * x / (1.0 + abs(k0 * x / f0) ** n) ** (1.0 / n) + kp * x


@njit(cache=True)
def richard_abbott_step(u, p, st):
    """Richard-Abbott force (seed 000 Eq. 2) at slip ``u`` with Masing's rules: the virgin
    backbone g(u); after a reversal at (u_r, F_r) the branch F_r + 2 g((u - u_r) / 2),
    back on the backbone once |u| passes its largest value so far. ``st`` is updated.

    >>> import numpy as np
    >>> st = np.zeros(N_RA_STATE); st[6] = 1.0
    >>> p = np.array([1.0e6, 0.0, 10.0, 2.0])
    >>> f = [richard_abbott_step(u, p, st) for u in (1e-5, 2e-5, 0.0, -2e-5, 0.0, 2e-5)]
    >>> round(f[1], 6) == round(-f[3], 6), f[5] == f[1]
    (True, True)
    """
    k0, kp, f0, n = p[0], p[1], p[2], p[3]
    du = u - st[0]
    if du != 0.0:
        d = 1.0 if du > 0.0 else -1.0
        if st[4] != 0.0 and d != st[4]:
            st[1] = st[0]
            st[2] = st[5]
            st[6] = 0.0
        st[4] = d
    if abs(u) >= st[3] and (st[6] == 1.0 or u * st[4] > 0.0):
        st[3] = abs(u)
        st[6] = 1.0
    if st[6] == 1.0:
        f = _backbone(u, k0, kp, f0, n)
    else:
        f = st[2] + 2.0 * _backbone(0.5 * (u - st[1]), k0, kp, f0, n)
    st[0] = u
    st[5] = f
    return f


@njit(cache=True, fastmath=True)
def integrate(n_samples, n_sub, dt, par, omega, c_modal, phi_drive, phi_acc, phi_joint,
              radius, k_stick, k_res, k_el, phi_slip, c_t, eta, etad, accp, z, state, out,
              law, ra, ras, iw, ist, ihist):
    """Advance ``n_samples`` samples of ``n_sub`` steps; fill ``out`` (rows above, then one per
    accelerometer) with the values at each sample's last step. ``accp``: last accelerations.
    ``law`` 0: the sliders ``phi_slip`` (stiffness ``k_el`` each); 1: Richard-Abbott threads
    (``ra`` rows k_e - k_p, k_p, F_0, n; ``ras`` their Masing state,
    :func:`richard_abbott_step`); 2: the continuous Iwan (``iw`` its backbone's parameters,
    ``ist``/``ihist`` each thread's state, :func:`~.structure_iwan.iwan_step`)."""
    amp, off, w, on, gain = par[0], par[1], par[2], par[3], par[4]
    res, ind, bl, cs, ks, ma = par[5], par[6], par[7], par[8], par[9], par[10]
    n_m = omega.size
    n_j = phi_joint.shape[0]
    n_e = phi_slip.shape[1]
    n_a = phi_acc.shape[0]
    vel = eta.copy()
    fj = k_stick.copy()
    uj = k_stick.copy()
    phase, cur, u_prev = state[0], state[1], state[2]
    v = 0.0
    xd = 0.0
    vd = 0.0
    for s in range(n_samples):
        for _ in range(n_sub):
            v = on * (amp * math.sin(phase) + off)
            phase += w * dt
            if phase > 2 * math.pi:
                phase -= 2 * math.pi
            xd = 0.0
            vd = 0.0
            for m in range(n_m):
                vel[m] = etad[m] + 0.5 * dt * accp[m]
                xd += phi_drive[m] * eta[m]
                vd += phi_drive[m] * vel[m]
            u_in = gain * v - bl * vd
            if ind > 0:
                h = 0.5 * dt * res / ind
                cur = ((1.0 - h) * cur + 0.5 * dt / ind * (u_in + u_prev)) / (1.0 + h)
            else:
                cur = u_in / res
            u_prev = u_in
            f_drive = bl * cur - cs * vd
            for m in range(n_m):
                accp[m] = phi_drive[m] * f_drive - c_modal[m] * vel[m] - omega[m] * omega[m] * eta[m]
            for j in range(n_j):
                th = 0.0
                thd = 0.0
                for m in range(n_m):
                    th += phi_joint[j, m] * eta[m]
                    thd += phi_joint[j, m] * vel[m]
                u = radius * th
                if law == 1:
                    f = richard_abbott_step(u, ra[j], ras[j])
                    n_e_j = 0
                elif law == 2:
                    f = k_res[j] * u + iwan_step(u, iw, ist, ihist, j)
                    n_e_j = 0
                else:
                    f = k_res[j] * u
                    n_e_j = n_e
                for e in range(n_e_j):
                    d = u - z[j, e]
                    lim = phi_slip[j, e]
                    if d > lim:
                        z[j, e] = u - lim
                        d = lim
                    elif d < -lim:
                        z[j, e] = u + lim
                        d = -lim
                    f += k_el[j] * d
                uj[j] = u
                fj[j] = f + c_t[j] * radius * thd
                moment = radius * (fj[j] - k_stick[j] * u)
                for m in range(n_m):
                    accp[m] -= phi_joint[j, m] * moment
            if _ < n_sub - 1:
                for m in range(n_m):
                    etad[m] += dt * accp[m]
                    eta[m] += dt * etad[m]
        # outputs at this step's time (before its update), all consistent
        a_drive = 0.0
        for m in range(n_m):
            a_drive += phi_drive[m] * accp[m]
        out[FORCE, s] = bl * cur - cs * vd - ks * xd - ma * a_drive
        out[V_GEN, s] = v
        out[V_AMP, s] = gain * v
        out[CURRENT, s] = cur
        out[U0, s] = uj[0]
        out[F0, s] = fj[0]
        out[U1, s] = uj[n_j - 1]
        out[F1, s] = fj[n_j - 1]
        for i in range(n_a):
            a = 0.0
            for m in range(n_m):
                a += phi_acc[i, m] * accp[m]
            out[ACC + i, s] = a
        for m in range(n_m):
            etad[m] += dt * accp[m]
            eta[m] += dt * etad[m]
    state[0] = phase
    state[1] = cur
    state[2] = u_prev
