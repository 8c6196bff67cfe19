"""The shaker path's first-order lag in the modal model (nlmode eq. 4b, ``shaker.lag_s``:
the coil's L / R, a sensor's decoder, anti-alias filters), against independent
generators written here: the lag's steady state on a sine in closed form, and two modes
driven through a lag by a multisine voltage, integrated by scipy's DOP853 (the lag as a
state), from which the modal fit recovers the lag."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from labjoint.compare.kinds.modal_prepare import prepare_modal
from labjoint.compare.kinds.modal_fit import fit_modal
from labjoint.storage.channels import Channel, ChannelRecord
from labjoint.structure.nlmode import Drive, ModalBasis

FS = 512.0
TAU = 4e-4
MODES = ((20.0, 0.01, 1.0), (90.0, 0.02, -0.8))     # f (Hz), zeta, participation at the sensor
GAIN = (3.0, 5.0)                                   # modal force per volt (m/s^2 per V)
TONES = np.arange(5.0, 150.0, 3.0)


def test_the_lag_of_a_steady_sine_is_its_closed_form():
    """On a fine grid holding a sine exactly, the lagged drive is the lag's steady state
    Re(V / (1 + i w tau) e^{i w t}) from the first sample on (the filter starts steady)."""
    f, fs, sub, n = 90.0, 1024.0, 10, 2048
    tf = np.arange((n - 1) * 2 * sub + 1) / (fs * 2 * sub)
    ph = 0.7 * np.exp(0.4j)
    d = Drive(np.real(ph * np.exp(2j * np.pi * f * tf)), fs, n, f, ph, sub)
    lag = d.lagged(TAU)
    exact = np.real(ph / (1 + 2j * np.pi * f * TAU) * np.exp(2j * np.pi * f * tf))
    assert np.max(np.abs(lag.fine - exact)) < 1e-4 * 0.7
    assert lag.phasor == pytest.approx(ph / (1 + 2j * np.pi * f * TAU), rel=1e-12)
    assert d.lagged(0.0) is d


def _volts(t):
    rng = np.random.default_rng(3)
    ph = rng.uniform(0, 2 * np.pi, TONES.size)
    return 0.02 * np.sum(np.sin(2 * np.pi * TONES[:, None] * t[None, :] + ph[:, None]), axis=0)


def _record(seconds=3.0):
    """The sensor's velocity: two modes driven by the lagged voltage (DOP853)."""
    w = [2 * np.pi * f for f, _, _ in MODES]

    def rhs(t, s):
        vl = s[0]
        out = [(_volts(np.array([t]))[0] - vl) / TAU]
        for j, (f, z, _) in enumerate(MODES):
            q, dq = s[1 + 2 * j], s[2 + 2 * j]
            out += [dq, GAIN[j] * vl - 2 * z * w[j] * dq - w[j] ** 2 * q]
        return out

    t = np.arange(int(seconds * FS)) / FS
    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(5), t_eval=t, method="DOP853", rtol=1e-9, atol=1e-13)
    vel = sum(p * sol.y[2 + 2 * j] for j, (_, _, p) in enumerate(MODES))
    chans = {"v": Channel("v", _volts(t), "voltage", "V", "drive"),
             "s": Channel("s", vel, "velocity", "m/s", "response")}
    return ChannelRecord("multisine", t, FS, chans, {})


def test_the_modal_fit_recovers_the_lag_of_the_drive():
    rec = _record()
    basis = ModalBasis.from_dict({"reference": "s", "modes": [
        {"frequency_hz": f, "damping_ratio": z, "shape": {"s": [p / MODES[0][2], 0.0]}}
        for f, z, p in MODES]})
    m = prepare_modal(rec, basis, ["s"])
    r = fit_modal("linear_stiffness+viscous", [m], [], bounds={"shaker.highpass_hz": (0.0, 0.0)})
    v = r.params_.valuesdict()
    assert v["shaker.lag_s"] == pytest.approx(TAU, rel=0.03)
    assert r.nrmse_ < 5e-3, r.nrmse_
    # without the lag the same model is far off at mode 2 (its phase: 13 deg at 90 Hz)
    r0 = fit_modal("linear_stiffness+viscous", [m], [], bounds={"shaker.highpass_hz": (0.0, 0.0),
                                                                  "shaker.lag_s": (0.0, 0.0)})
    assert r0.nrmse_ > 10 * r.nrmse_, (r0.nrmse_, r.nrmse_)
