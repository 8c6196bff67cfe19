"""Friction (seed 002 Eq. 10) and the stick-slip method (Eqs. 2-9) on another lab's CSV
from an independent generator: a Jenkins element in gross slip has a sliding force f_s,
so mu = f_s / N exactly (N = 478 N/Nm x torque, seed 002); what would fake or hide the
plateau (a clipped force, a sweep) is refused by name."""

import json

import numpy as np
import pytest

from foreign_sine import Record, jenkins, write_csv
from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.identify.methods import analyze_runs
from labjoint.storage.csv_parse import parse_csv

TORQUE, F_S = 2.0, 160.0
MU = F_S / (478.0 * TORQUE)
TEST = Record(joint="jenkins", k=12e6, f_s=F_S, U=60e-6, f=100.0, fs=25600.0, cycles=20)
META = {"torque_nm": TORQUE, "frequency_hz": 100}


def friction_cli(tmp_path, capsys, name, t, u, F, meta=META):
    path = write_csv(tmp_path / f"{name}.csv", t, u, F, meta)
    code = main(["friction", str(path), "--json", "--any-plan", "--quiet",
                 "--data-dir", str(tmp_path / "dd")])
    out, err = capsys.readouterr()
    return code, (json.loads(out) if code == 0 else err)


@pytest.mark.parametrize("record", [
    TEST,
    TEST.but(f=10.0, fs=10000.0, cycles=8, phase0=2.0),
    TEST.but(noise_u=1e-8, noise_f=0.5, offset_u=1e-5, offset_f=5.0, hum=1.0, seed=3)])
def test_friction_coefficient_is_the_sliding_force_over_the_normal_force(tmp_path, capsys,
                                                                          record):
    code, out = friction_cli(tmp_path, capsys, "friction", *record.arrays())
    assert code == 0, out
    assert out["friction_coefficient"] == pytest.approx(MU, rel=3e-3)
    assert out["normal_force_n"] == pytest.approx(478.0 * TORQUE)


def test_an_inverted_force_sensor_gives_the_same_coefficient(tmp_path, capsys):
    # the plateau's magnitude is what Eq. 10 reads: the sign does not enter
    t, u, F = TEST.arrays()
    code, out = friction_cli(tmp_path, capsys, "inverted", t, u, -F)
    assert code == 0 and out["friction_coefficient"] == pytest.approx(MU, rel=3e-3)


def test_a_clipped_force_is_refused_not_read_as_a_plateau(tmp_path, capsys):
    # before: a force clipped at 140 N gave mu = 140 / N, 12 % low, silently
    t, u, F = TEST.arrays()
    code, err = friction_cli(tmp_path, capsys, "clipped", t, u, np.clip(F, -140.0, 140.0))
    assert code != 0 and "'force'" in err and "clipped" in err and "friction" in err


def test_a_swept_friction_test_is_refused(tmp_path, capsys):
    t = np.arange(int(0.3 * TEST.fs)) / TEST.fs
    u = TEST.U * np.sin(2 * np.pi * (50 * t + 200 * t ** 2))
    code, err = friction_cli(tmp_path, capsys, "sweep", t, u, jenkins(u, TEST.k, F_S))
    assert code != 0 and "not a steady sine" in err and "friction" in err


def test_stick_slip_method_on_a_foreign_csv_keeps_the_loop_exact(tmp_path, capsys):
    r = Record(joint="jenkins", k=2e7, f_s=20.0, cycles=20, noise_f=0.01)
    path = write_csv(tmp_path / "joint.csv", *r.arrays(), {"torque_nm": 5})
    assert main(["analyze", str(path), "--method", "both", "--friction", "0.2", "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["runs"][0]
    assert row["energy_loss_j"] == pytest.approx(r.energy_loss, rel=3e-3)
    assert row["stickslip_displacement_amplitude_m"] == pytest.approx(r.U, rel=0.01)
    assert row["stickslip_energy_loss_j"] > 0 and row["friction_coefficient"] == 0.2


@pytest.mark.parametrize("case", ["sweep", "clipped"])
def test_stick_slip_method_with_a_given_stiffness_refuses_what_the_loop_would(tmp_path, case):
    # with K_t given the loop pipeline is not run; before, a sweep and a clipped
    # displacement went through Eqs. 2-9 as if they were steady sines
    fs = 25600.0
    t = np.arange(int(0.4 * fs)) / fs
    if case == "sweep":
        u = 5e-6 * np.sin(2 * np.pi * (50 * t + 200 * t ** 2))
    else:
        u = np.clip(5e-6 * np.sin(2 * np.pi * 100 * t + 0.7), -4e-6, 4e-6)
    path = write_csv(tmp_path / f"{case}.csv", t, u, 2e6 * u, {"torque_nm": 5})
    run = parse_csv(path).to_run()
    with pytest.raises(InputError, match="not a steady sine" if case == "sweep" else "clipped"):
        analyze_runs([run], "stickslip", friction=0.2, shear_stiffness=1e7)
