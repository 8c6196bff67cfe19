"""The modal kind's split of a sine set (issue 29 item 8) against an independent generator:
a softening Duffing oscillator (unit mass, x'' + 2 zeta w x' + w^2 x + k3 x^3 = b V(t),
k3 < 0) driven by a voltage sine, its velocity measured with noise, integrated here by
scipy's DOP853 from rest. The sines sit as BERT's did: two near the resonance among
others away from it, so that validating on every third sine by frequency (the old
rule) would hold out only sines where the cubic hardly acts; the alternating rule puts
one of the two resonant sines in each set, and diagnose must name the cubic there."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared
from labjoint.compare.kinds.modal_prepare import prepare_modal
from labjoint.compare.kinds.modal_fit import fit_modal
from labjoint.compare.kinds.modal_maps import MODAL
from labjoint.storage.channels import Channel, ChannelRecord
from labjoint.structure.nlmode import ModalBasis

FS = 200.0
F1, ZETA = 10.0, 0.02
W = 2 * np.pi * F1
K3 = -2.0e8                 # N/m^3 per kg: softening, ~3 % of the linear force at 1 mm
B, VOLTS = 1.0, 0.16        # modal force per volt (m/s^2 per V), drive amplitude (V)
SINES = (3.0, 6.0, 9.4, 9.8, 14.0, 16.0)


def _record(freq: float, seed: int, seconds: float = 10.0, noise: float = 5e-3) -> ChannelRecord:
    w = 2 * np.pi * freq

    def rhs(t, s):
        x, v = s
        return [v, B * VOLTS * np.sin(w * t) - 2 * ZETA * W * v - W * W * x - K3 * x**3]

    t = np.arange(int(seconds * FS)) / FS
    sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], t_eval=t, method="DOP853", rtol=1e-9, atol=1e-12)
    v = sol.y[1]
    rng = np.random.default_rng(seed)
    chans = {"input_V": Channel("input_V", VOLTS * np.sin(w * t), "voltage", "V", "drive"),
             "vel": Channel("vel", v + noise * v.std() * rng.standard_normal(v.size), "velocity",
                            "m/s", "response")}
    return ChannelRecord(f"sine_{freq:g}Hz", t, FS, chans, {"frequency_hz": freq})


@pytest.fixture(scope="module")
def sine_set():
    basis = ModalBasis.from_dict({"reference": "vel", "modes": [
        {"frequency_hz": F1, "damping_ratio": ZETA, "shape": {"vel": [1.0, 0.0]}}]})
    return [prepare_modal(_record(f, i), basis, ["vel"], warmup_s=5.0, judge_s=2.0)
            for i, f in enumerate(SINES)]


def test_neighbouring_sines_fall_in_different_sets(sine_set):
    fit, val, rule = MODAL.split(sine_set[::-1])          # the order given does not matter
    assert "alternate" in rule
    assert sorted(m.frequency_hz for m in val) == pytest.approx([6.0, 9.8, 16.0], abs=0.01)
    assert sorted(m.frequency_hz for m in fit) == pytest.approx([3.0, 9.4, 14.0], abs=0.01)
    # the two sines near the resonance (within 10 % of it) are one in each set
    near = lambda ms: [m for m in ms if abs(m.frequency_hz / F1 - 1) < 0.1]  # noqa: E731
    assert len(near(fit)) == 1 and len(near(val)) == 1


def test_softening_cubic_is_named_and_its_sign_and_size_recovered(sine_set):
    dg = diagnose_prepared(sine_set, "linear_stiffness+viscous",
                           settings=DiagnoseSettings(candidates=("quadratic_stiffness", "cubic_stiffness")))
    best = dg.best
    assert best is not None and best.effect == "cubic_stiffness", dg.verdict
    assert best.fit.params_["cubic_stiffness.k3"].value < 0          # softening, as generated
    assert best.nrmse_after_validation < 0.5 * dg.nrmse_validation
    # the named model fitted on every sine: k3 and k of the generator (unit modal mass: the
    # mode-1 coordinate is the measured velocity's displacement, phi = 1)
    fit = fit_modal("linear_stiffness+viscous+cubic_stiffness", sine_set)
    assert fit.params_["cubic_stiffness.k3"].value == pytest.approx(K3, rel=0.10)
    assert fit.params_["linear_stiffness.k"].value == pytest.approx(W * W, rel=0.005)
