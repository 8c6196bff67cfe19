"""The record-level simulator driven by a voltage through the shaker (issue 29 item 3),
against scipy's solve_ivp of the same physics written here: a coil (S1) and an armature
riding on a joint-level mass with a cubic joint."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from labjoint.errors import InputError
from labjoint.models.shaker import Shaker
from labjoint.models.simulate import shaker_outputs, simulate, simulate_states

M, C, K, K3 = 0.5, 4.0, 4.0e4, 1.0e11
PARAMS = {"inertia.m": M, "viscous.c": C, "linear_stiffness.k": K, "cubic_stiffness.k3": K3}
MODEL = "inertia+viscous+linear_stiffness+cubic_stiffness"
FS = 2000.0


def _volts(t):
    return 2.0 * np.sin(2 * np.pi * 37.0 * t) + 1.0 * np.sin(2 * np.pi * 61.0 * t + 0.4)


def _truth(sh, t):
    bl, R, L, G = sh.force_factor_n_per_a, sh.coil_resistance_ohm, sh.coil_inductance_h, sh.amplifier_gain_v_per_v
    mt = M + sh.armature_mass_kg

    def rhs(tt, s):
        x, v, i = s
        fj = C * v + K * x + K3 * x**3
        a = (bl * i - sh.suspension_damping_ns_per_m * v - sh.suspension_stiffness_n_per_m * x - fj) / mt
        return [v, a, (G * _volts(tt) - R * i - bl * v) / L]

    sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0, 0.0], t_eval=t, method="DOP853", rtol=1e-10, atol=1e-14)
    x, v, i = sol.y
    a = np.array([rhs(tt, s)[1] for tt, s in zip(t, sol.y.T)])
    F = bl * i - sh.armature_mass_kg * a - sh.suspension_damping_ns_per_m * v - sh.suspension_stiffness_n_per_m * x
    return x, F, i, a


def test_voltage_through_the_shaker_gives_displacement_and_force():
    sh = Shaker(0.05, 2.0e3, 3.0, 2.0, 2.0e-3, 8.0, 1.0)
    t = np.arange(int(0.5 * FS)) / FS
    x, F, i, _ = _truth(sh, t)
    out = shaker_outputs(simulate_states(MODEL, PARAMS, _volts(t), FS, shaker=sh), sh, _volts(t))
    rel = lambda a, b: np.sqrt(np.mean((a - b) ** 2)) / np.std(b)  # noqa: E731
    assert rel(out["displacement"], x) < 1e-3
    assert rel(out["coil_current"], i) < 1e-3
    assert rel(out["force"], F) < 2e-3
    assert np.max(np.abs(x)) > 1e-4 and K3 * np.max(np.abs(x)) ** 2 > 0.2 * K   # the cubic acts
    # per newton: the force the shaker gives, fed to the force-driven simulator, gives the same motion
    back = simulate(MODEL, PARAMS, out["force"], FS)
    assert rel(back, x) < 5e-3


def test_coil_without_inductance_and_a_coil_too_fast_for_the_record():
    sh0 = Shaker(0.05, 2.0e3, 3.0, 2.0, 0.0, 8.0, 1.0)
    sh1 = Shaker(0.05, 2.0e3, 3.0, 2.0, 1e-7, 8.0, 1.0)          # corner 3 MHz
    t = np.arange(int(0.3 * FS)) / FS
    with pytest.raises(InputError, match="coil_inductance_h = 0") as e:
        simulate_states(MODEL, PARAMS, _volts(t), FS, shaker=sh1)
    assert e.value.field == "shaker.coil_inductance_h"
    sh2 = Shaker(0.05, 2.0e3, 3.0, 2.0, 2e-6, 8.0, 1.0)           # corner 160 kHz: L = 0's limit
    a = simulate_states(MODEL, PARAMS, _volts(t), FS, shaker=sh0)[:, 0]
    b = simulate_states(MODEL, PARAMS, _volts(t), FS, shaker=sh2)[:, 0]
    assert np.sqrt(np.mean((a - b) ** 2)) < 5e-4 * np.std(a)      # the lag, 60 Hz / 160 kHz, is 4e-4


def test_predict_through_the_shaker_cli(tmp_path, capsys):
    """`labjoint predict MODEL.json RECORD --shaker S.toml`: the response per volt in its own
    quantity (acceleration here) and the force on the structure, both against the generator."""
    import json

    from labjoint.cli.main import main
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    sh = Shaker(0.05, 2.0e3, 3.0, 2.0, 2.0e-3, 8.0, 1.0)
    t = np.arange(int(0.5 * FS)) / FS
    x, F, i, a = _truth(sh, t)
    spec = lambda n, q, u: ChannelSpec(n, "imported", q, u, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
    rec = store_channels(tmp_path / "r.h5", t, FS, [(spec("input_V", "voltage", "V"), _volts(t)),
                                                    (spec("acc", "acceleration", "m/s^2"), a),
                                                    (spec("stinger_N", "force", "N"), F)],
                         {"drive_channels": ["input_V"], "response_channels": ["acc"]}, tmp_path / "d", name="r")
    model = tmp_path / "m.json"
    model.write_text(json.dumps({"format": "labjoint-model/1", "model": MODEL,
                                 "parameters": {k: {"value": v} for k, v in PARAMS.items()}}))
    s_toml = tmp_path / "s.toml"
    s_toml.write_text("[shaker]\n" + "".join(f"{k} = {v!r}\n" for k, v in sh.to_dict().items()))
    assert main(["predict", str(model), str(rec), "--shaker", str(s_toml), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["response"] == "acc" and res["channels"]["acc"]["quantity"] == "acceleration"
    assert res["channels"]["acc"]["nrmse"] < 2e-3 and res["channels"]["stinger_N"]["nrmse"] < 2e-3
    s_toml.write_text("[shaker]\nforce_factor_n_per_a = 8.0\n")
    assert main(["predict", str(model), str(rec), "--shaker", str(s_toml), "--json"]) == 2
    err = capsys.readouterr()
    assert err.out == "" and "armature_mass_kg" in err.err
