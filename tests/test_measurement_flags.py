"""Flags for a user's mistakes (issue 29 item 7): a negative measured energy loss in the
fit / diagnose / analyze JSON and text; against a loop of known W written here."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from labjoint.compare import fit_runs

LABJOINT = [sys.executable, "-m", "labjoint.cli.main"]


def _csv(path, c, amp=2e-5, f=10.0, fs=2000.0, k=1e6):
    """A linear loop F = k u + c v: W = pi c w U^2 per cycle (negative for c < 0)."""
    t = np.arange(int(4 * fs)) / fs
    u = amp * np.sin(2 * np.pi * f * t)
    F = k * u + c * amp * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
    rows = "\n".join(f"{a:.6f},{b:.9e},{x:.9e}" for a, b, x in zip(t, u, F))
    path.write_text(f"# frequency_hz: {f}\n# sample_rate_hz: {fs}\ntime_s,displacement_m,force_N\n{rows}\n")
    return path


def test_negative_energy_loss_flagged_in_fit_json(tmp_path):
    bad, good = _csv(tmp_path / "backwards.csv", c=-50.0), _csv(tmp_path / "fine.csv", c=50.0)
    res = fit_runs([bad], "linear_stiffness+viscous")
    (flag,) = res["measurement_flags"]
    w = np.pi * -50.0 * 2 * np.pi * 10.0 * (2e-5) ** 2
    assert flag["run"] == "backwards" and flag["flag"] == "negative_energy_loss"
    assert flag["energy_loss_j"] == pytest.approx(w, rel=0.02)
    assert "sign" in flag["message"] and "voltage" in flag["message"]
    assert "measurement_flags" not in fit_runs([good], "linear_stiffness+viscous")


def test_negative_energy_loss_in_analyze_and_fit_text(tmp_path):
    bad = _csv(tmp_path / "backwards.csv", c=-50.0)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    r = subprocess.run([*LABJOINT, "analyze", str(bad), "--json"], capture_output=True, text=True, env=env,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    (row,) = json.loads(r.stdout)["runs"]
    assert row["flags"][0]["flag"] == "negative_energy_loss"
    r = subprocess.run([*LABJOINT, "fit", str(bad), "--model", "linear_stiffness+viscous"], capture_output=True,
                       text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "warning: run backwards: measured energy loss" in r.stdout


def test_negative_energy_loss_on_a_record(tmp_path):
    """A broadband record (the record kind: W = sum of F v / fs) run backwards."""
    fs, rng = 2000.0, np.random.default_rng(1)
    t = np.arange(int(4 * fs)) / fs
    freqs = np.arange(5.0, 80.0, 2.5)
    ph = rng.uniform(0, 2 * np.pi, freqs.size)
    u = 1e-5 * np.sin(2 * np.pi * np.multiply.outer(t, freqs) + ph).sum(-1) / np.sqrt(freqs.size)
    v = 1e-5 * (2 * np.pi * freqs * np.cos(2 * np.pi * np.multiply.outer(t, freqs) + ph)).sum(-1) / np.sqrt(freqs.size)
    for name, c in (("backwards", -30.0), ("fine", 30.0)):
        F = 1e6 * u + c * v
        rows = "\n".join(f"{a:.6f},{b:.9e},{x:.9e}" for a, b, x in zip(t, u, F))
        (tmp_path / f"{name}.csv").write_text(f"# sample_rate_hz: {fs}\ntime_s,displacement_m,force_N\n{rows}\n")
    res = fit_runs([tmp_path / "backwards.csv"], "linear_stiffness+viscous", kind="record")
    assert res["measurement_flags"][0]["run"] == "backwards"
    assert "measurement_flags" not in fit_runs([tmp_path / "fine.csv"], "linear_stiffness+viscous", kind="record")


def test_complex_modes_flagged_for_the_modal_kind(tmp_path):
    """The 2-DOF chain driven through a strongly coupled coil (tests/spectra_runs.py: the
    back-EMF damps mass 1 only, so its modes are complex) measured as a user would
    (`labjoint modes`): mode 2 is flagged at vel1 with the closed form's phase; the same
    chain driven by a force (proportional damping, real modes) is not."""
    from labjoint.compare.flags import complex_mode_flags, measurement_flags
    from labjoint.compare.modal_api import load_modal
    from labjoint.structure.nlmode import ModalBasis
    from spectra_runs import measured_modes as _modes_of, random_force, random_voltage, state

    lam, vec = np.linalg.eig(state(True)[0])
    order = [i for i in np.argsort(np.abs(lam)) if lam[i].imag > 0]
    phases = []
    for i in order:                                   # vel1 / vel2 of each structural mode
        a = abs(np.degrees(np.angle(vec[2, i] / vec[3, i])))
        phases.append(min(a, 180 - a))
    volt, force = random_voltage(tmp_path / "v.h5", 0.3, seed=3, n=1 << 13), \
        random_force(tmp_path / "f.h5", 2.0, seed=3, n=1 << 13)
    flags = measurement_flags(load_modal([volt], None, {"modal": _modes_of(volt)})[0])
    assert [f["mode"] for f in flags] == [2] and flags[0]["flag"] == "complex_mode"
    assert flags[0]["sensor"] == "vel1"
    assert flags[0]["phase_deg"] == pytest.approx(phases[1], abs=1.5)
    assert "quadrature" in flags[0]["message"] and flags[0]["carried"]
    pair = measurement_flags(load_modal([volt], None, {"modal": _modes_of(volt), "between": "vel1,vel2"})[0])
    assert pair[0]["carried"] and "measured imaginary part" in pair[0]["message"]
    assert measurement_flags(load_modal([force], None, {"modal": _modes_of(force)})[0]) == []
    # the phase is taken where the shape is seen: a sensor below 10 % of the largest is not
    b = ModalBasis.from_dict({"reference": "a", "modes": [{"frequency_hz": 10.0, "damping_ratio": 0.01,
        "shape": {"a": [1.0, 0.0], "b": [0.5 * np.cos(0.3), 0.5 * np.sin(0.3)], "c": [0.0, 0.05]}}]})
    assert b.modes[0].phase_deg == pytest.approx(np.degrees(0.3)) and b.modes[0].phase_sensor == "b"
    assert b.modes[0].shape == {"a": 1.0, "b": pytest.approx(0.5 * np.cos(0.3)), "c": 0.0}
    assert complex_mode_flags(b)[0]["mode"] == 1


def test_a_flag_without_a_run_prints_its_message(capsys):
    from labjoint.cli.limits import print_flags

    print_flags({"measurement_flags": [{"flag": "complex_mode", "message": "mode 2 is complex"},
                                       {"run": "r1", "flag": "x", "message": "m"}]})
    assert capsys.readouterr().out == "warning: mode 2 is complex\nwarning: run r1: m\n"
