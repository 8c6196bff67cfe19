"""The simulation-error fit never collapses (issue 29 item 6): an unstable start is
recovered from the records' FRF or refused by name, never reported or saved with NaN;
--start and --bound; predict --warmup. Records from a closed-form generator written here
(the exact periodic steady state of m y'' + c y' + k y = F, line by line), not labjoint's
simulator."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.compare.kinds import prepare
from labjoint.compare.output_error import fit_prepared, prepare_records
from labjoint.compare.sim_start import frf_start
from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.storage import Run

FS = 750.0
N = 1024
M, C, K = 2.0, 10.0, 5e4            # resonance 25.2 Hz, inside the 5-150 Hz band
EXPR = "inertia+viscous+linear_stiffness"


def steady_record(name: str, periods: int = 4, seed: int = 1, noise: float = 1e-7,
                  rms: float = 50.0) -> Run:
    """A multisine force (5-150 Hz) and the oscillator's exact steady displacement."""
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(N, 1 / FS)
    sel = (f >= 5) & (f <= 150)
    spec = np.zeros(f.size, complex)
    spec[sel] = np.exp(2j * np.pi * rng.random(sel.sum()))
    w = 2 * np.pi * f
    H = 1.0 / (K - M * w ** 2 + 1j * C * w)
    F1 = np.fft.irfft(spec, N)
    y1 = np.fft.irfft(spec * H, N)
    g = rms / np.std(F1)
    F, y = np.tile(F1 * g, periods), np.tile(y1 * g, periods)
    y = y + noise * rng.standard_normal(y.size)
    return Run(name, np.arange(F.size) / FS, y, F, {"sample_rate_hz": FS})


def _csv(path, run: Run):
    body = np.column_stack([run.time, run.displacement, run.force])
    with open(path, "w") as fh:
        fh.write(f"# sample_rate_hz: {FS}\ntime_s,displacement_m,force_N\n")
        np.savetxt(fh, body, delimiter=",", fmt="%.12g")
    return path


def _recs(*runs: Run):
    return prepare(list(runs), kind="record", warmup=0)


def test_the_frf_start_of_a_linear_oscillator_is_its_m_c_k():
    start = frf_start(_recs(steady_record("r")))
    assert start["inertia.m"] == pytest.approx(M, rel=0.05)
    assert start["linear_stiffness.k"] == pytest.approx(K, rel=0.05)
    assert start["viscous.c"] == pytest.approx(C, rel=0.3)


def two_mass_record(periods: int = 4, seed: int = 1) -> Run:
    """Force on mass 1 of a two-mass chain (ground -k1- m1 -k2- m2), displacement measured
    on mass 2: the exact steady state, line by line. Read as one mass (the user's model),
    the equation error comes out unstable, as on the BERT cantilever (m ~ 0, k < 0)."""
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(N, 1 / FS)
    sel = (f >= 5) & (f <= 150)
    spec = np.zeros(f.size, complex)
    spec[sel] = np.exp(2j * np.pi * rng.random(sel.sum()))
    w = 2 * np.pi * f
    m1, c1, k1, m2, c2, k2 = 2.0, 10.0, 5e4, 0.5, 2.0, 2e4
    a11 = k1 + k2 - m1 * w ** 2 + 1j * w * (c1 + c2)
    a12 = -(k2 + 1j * w * c2)
    a22 = k2 - m2 * w ** 2 + 1j * w * c2
    H2 = -a12 / (a11 * a22 - a12 * a12)
    F1 = np.fft.irfft(spec, N)
    g = 50.0 / np.std(F1)
    y, F = np.tile(np.fft.irfft(spec * H2, N) * g, periods), np.tile(F1 * g, periods)
    return Run("two_mass", np.arange(F.size) / FS, y, F, {"sample_rate_hz": FS})


def test_an_unstable_equation_error_start_is_recovered_never_nan():
    from labjoint.compare.api import fit_report

    recs = prepare_records([two_mass_record()], periodic=True)
    eq = fit_report(recs, EXPR).fit.params_
    assert eq["linear_stiffness.k"].value < 0            # the start is unstable
    fit = fit_prepared(recs, Model.parse(EXPR), periodic=True)
    assert fit.params["inertia.m"].value > 0 and fit.params["linear_stiffness.k"].value > 0
    assert math.isfinite(fit.nrmse()) and fit.nrmse() < 0.6
    assert any("FRF" in w and "unstable" in w for w in fit.warnings)
    json.dumps(fit.to_dict(), allow_nan=False)          # nothing non-finite to print or save


def test_a_start_that_diverges_is_refused_naming_what_diverged(tmp_path, capsys):
    """A negative stiffness the user insists on, bounded so the search cannot leave it: the
    simulation grows without bound, and the fit is refused (exit 2, one line, no file)."""
    rec = _csv(tmp_path / "r.csv", steady_record("r"))
    out = tmp_path / "model.json"
    code = main(["fit", str(rec), "--model", EXPR, "--error", "simulation", "--warmup", "0",
                 "--start", "linear_stiffness.k=-5e4", "--bound", "linear_stiffness.k=-1e5:-1e4",
                 "--out", str(out), "--json"])
    cap = capsys.readouterr()
    assert code == 2 and cap.out == "" and not out.exists()
    assert "diverged" in cap.err and "linear_stiffness.k" in cap.err
    assert "nan" not in cap.err.lower().replace("nan ", "")


def test_start_and_bound_are_checked_by_name(tmp_path, capsys):
    rec = _csv(tmp_path / "r.csv", steady_record("r"))
    base = ["fit", str(rec), "--model", EXPR, "--error", "simulation", "--json"]
    assert main(base + ["--start", "inertia.m=-1"]) == 2
    assert "start.inertia.m" in capsys.readouterr().err
    assert main(base + ["--start", "iwan.K_T=1"]) == 2
    assert "start.iwan.K_T" in capsys.readouterr().err
    assert main(base + ["--bound", "viscous.c=5:1"]) == 2
    assert "bound.viscous.c" in capsys.readouterr().err
    assert main(["fit", str(rec), "--model", EXPR, "--start", "inertia.m=1", "--json"]) == 2
    assert "--start goes with --error simulation" in capsys.readouterr().err


def test_fit_out_and_predict_warmup_write_only_finite_numbers(tmp_path, capsys):
    rec = _csv(tmp_path / "r.csv", steady_record("r"))
    out = tmp_path / "model.json"
    assert main(["fit", str(rec), "--model", EXPR, "--error", "simulation", "--periodic",
                 "--start", "inertia.m=1.9,viscous.c=9", "--out", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["parameters"]["inertia.m"]["value"] == pytest.approx(M, rel=0.01)
    saved = json.loads(out.read_text())
    assert all(v["stderr"] is None or math.isfinite(v["stderr"]) for v in saved["parameters"].values())
    test = _csv(tmp_path / "t.csv", steady_record("t", periods=3, seed=7))
    assert main(["predict", str(out), str(test), "--warmup", "1.0", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["samples"] <= 3 * N - int(round(1.0 * FS))
    assert res["nrmse"] < 1e-2 and res["warmup"] == "1.0"
    assert main(["predict", str(out), str(test), "--warmup", "-1", "--json"]) == 2
    assert "warmup" in capsys.readouterr().err


def test_a_voltage_or_acceleration_where_the_model_needs_a_force_or_displacement_is_refused():
    """Channels that state their quantity (imported files do) are guarded by it: a drive
    voltage is never taken as the model's force, an acceleration never as displacement."""
    r = steady_record("volts")
    chans = {"displacement": r.displacement, "force": r.force}
    for q, field in (({"force": "voltage", "displacement": "displacement"}, "force"),
                     ({"force": "force", "displacement": "acceleration"}, "displacement")):
        run = Run("volts", r.time, r.displacement, r.force,
                  {"sample_rate_hz": FS, "channel_quantities": q,
                   "displacement_channels": ["displacement"], "joint_force_channel": "force"},
                  chans)
        with pytest.raises(InputError, match=f"channel '{field}' is a {q[field]}") as exc:
            prepare([run], kind="record", warmup=0)
        assert exc.value.field == field
    ok = Run("ok", r.time, r.displacement, r.force,
             {"sample_rate_hz": FS, "channel_quantities": {"force": "force", "displacement": "displacement"},
              "displacement_channels": ["displacement"], "joint_force_channel": "force"}, chans)
    assert prepare([ok], kind="record", warmup=0)[0].name == "ok"
