"""Time integration of the rig: two shaker armatures, two links, two beams and the joint.

Degrees of freedom q = [x_a1, x_1, x_2, x_a2] (armature 1, beam 1, beam 2, armature 2),
positive in one direction along the beams; u = x_1 - x_2. Shaker 1 pushes with
G K_f V(t), shaker 2 with -balance G K_f V(t) (antiphase). The joint force F(u) acts
on beam 1 as -F and on beam 2 as +F, so a sticking joint gives F = K u.

Velocity Verlet (explicit, second order, stable for omega dt < 2; the stiffest mode of
the default rig is ~1 kHz, so a 10 us step has omega dt ~ 0.07); damping and viscous
forces use the predicted end-of-step velocity. The hysteretic elements are stepped with
the displacement increment, so their path is exact for a piecewise-linear u.
"""

from __future__ import annotations

import math

from numba import njit

from labjoint.hardware.sim.joint import F0, M_IN, N_JOINT_STATE, joint_force

# drive array: half Vpp, offset V, omega, output on, G*K_f (N/V), balance
# dyn array: armature mass, suspension k, suspension c, link k, link c, m1, m2, support k, support c
# st array: phase, then the joint state (joint.N_JOINT_STATE: u_eff previous, dissipated
# energy, layer y, element force)
# out rows:
X1M, X2M, FL1M, FL2M, FSM, NCV, DRIVE, X1, X2, FJ, ED = range(11)
N_OUT = 11
# delay buffer rows: x1, x2, link 1, link 2, sensed joint force
N_DELAY = 5


@njit(cache=True, inline="always")
def _accel(q, v, fs1, fs2, fj, dyn, acc):
    ma, ks, cs, kl, cl, m1, m2, kb, cb = dyn[0], dyn[1], dyn[2], dyn[3], dyn[4], dyn[5], dyn[6], dyn[7], dyn[8]
    fl1 = kl * (q[0] - q[1]) + cl * (v[0] - v[1])
    fl2 = kl * (q[3] - q[2]) + cl * (v[3] - v[2])
    acc[0] = (fs1 - ks * q[0] - cs * v[0] - fl1) / ma
    acc[1] = (fl1 - kb * q[1] - cb * v[1] - fj) / m1
    acc[2] = (fl2 - kb * q[2] - cb * v[2] + fj) / m2
    acc[3] = (fs2 - ks * q[3] - cs * v[3] - fl2) / ma
    return fl1, fl2


@njit(cache=True, inline="always")
def _biquads(x, sos, zi):
    # cascade of direct-form-II-transposed sections: sos rows [b0, b1, b2, 1, a1, a2]
    y = x
    for s in range(sos.shape[0]):
        out = sos[s, 0] * y + zi[s, 0]
        zi[s, 0] = sos[s, 1] * y - sos[s, 4] * out + zi[s, 1]
        zi[s, 1] = sos[s, 2] * y - sos[s, 5] * out
        y = out
    return y


@njit(cache=True, fastmath=True)
def integrate(n_samples, n_sub, dt, drive, wave, dyn, q, v, acc, st,
              jk, jphi, jz, sm_code, sm_par, sm_st, eff,
              dbuf, didx, delay_steps, delay_group, nc_sos, nc_zi, out):
    """Advance ``n_samples`` samples of ``n_sub`` steps ``dt``; write sample rows into ``out``.

    Every state array is updated in place, so calls continue seamlessly (phase included).
    ``wave`` empty: the drive is a sine; else one period of the generator's arbitrary
    waveform, each point held for its share of the period (the generator's staircase).
    """
    vamp, voff, omega, on, gk, bal = drive[0], drive[1], drive[2], drive[3], drive[4], drive[5]
    vp = q.copy()
    js = st[1:1 + N_JOINT_STATE].copy()
    nbuf = dbuf.shape[1]
    d_int = int(delay_steps)
    d_frac = delay_steps - d_int
    two_pi = 2.0 * math.pi
    n_wave = wave.shape[0]
    per_rad = n_wave / two_pi
    phase = st[0]
    fj = 0.0
    fl1 = 0.0
    fl2 = 0.0
    volts = 0.0
    ncv = 0.0
    fsense = 0.0
    j0 = 0
    j1 = 0
    for k in range(n_samples):
        for _ in range(n_sub):
            phase += omega * dt
            if phase > two_pi:
                phase -= two_pi
            if on <= 0.0:
                volts = 0.0
            elif n_wave == 0:
                volts = voff + vamp * math.sin(phase)
            else:
                iw = int(phase * per_rad)
                volts = voff + vamp * wave[iw if iw < n_wave else n_wave - 1]
            fs1 = gk * volts
            fs2 = -bal * gk * volts
            for i in range(4):
                v[i] += 0.5 * dt * acc[i]
                q[i] += dt * v[i]
            for i in range(4):
                vp[i] = v[i] + 0.5 * dt * acc[i]
            fj = joint_force(q[1] - q[2], vp[1] - vp[2], dt, js, jk, jphi, jz, sm_code, sm_par, sm_st, eff)
            fl1, fl2 = _accel(q, vp, fs1, fs2, fj, dyn, acc)
            for i in range(4):
                v[i] += 0.5 * dt * acc[i]
            fsense = fj + eff[F0] + eff[M_IN] * (acc[1] - acc[2])
            if delay_group != 0:
                # delay line at the step rate (linear interpolation: error ~ (omega dt)^2 / 8)
                j = didx[0]
                dbuf[0, j] = q[1]
                dbuf[1, j] = q[2]
                dbuf[2, j] = fl1
                dbuf[3, j] = fl2
                dbuf[4, j] = fsense
                j0 = j - d_int
                if j0 < 0:
                    j0 += nbuf
                j1 = j0 - 1 if j0 > 0 else nbuf - 1
                j += 1
                didx[0] = j if j < nbuf else 0
                if delay_group == 1:
                    fsense = (1.0 - d_frac) * dbuf[4, j0] + d_frac * dbuf[4, j1]
            ncv = _biquads(fsense, nc_sos, nc_zi)
        out[DRIVE, k] = volts
        out[X1, k] = q[1]
        out[X2, k] = q[2]
        out[FJ, k] = fj + eff[F0]
        out[ED, k] = js[1]
        out[NCV, k] = ncv
        out[FSM, k] = fsense
        if delay_group == 1:
            out[FL1M, k] = (1.0 - d_frac) * dbuf[2, j0] + d_frac * dbuf[2, j1]
            out[FL2M, k] = (1.0 - d_frac) * dbuf[3, j0] + d_frac * dbuf[3, j1]
        else:
            out[FL1M, k] = fl1
            out[FL2M, k] = fl2
        if delay_group == 2:
            out[X1M, k] = (1.0 - d_frac) * dbuf[0, j0] + d_frac * dbuf[0, j1]
            out[X2M, k] = (1.0 - d_frac) * dbuf[1, j0] + d_frac * dbuf[1, j1]
        else:
            out[X1M, k] = q[1]
            out[X2M, k] = q[2]
    st[0] = phase
    st[1:1 + N_JOINT_STATE] = js
