"""Trends over runs (issue 17 item 11): the dissipation exponent of seed 001 (W ~ F^n by
weighted least squares on log axes) on synthetic data of known exponent, and the trends
of simulated amplitude sweeps through the Python layer and `labjoint analyze --table`."""

from __future__ import annotations

import contextlib
import io
import json
import re

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.identify.powerlaw import fit_power_law
from labjoint.identify.trends import build_trends, trend_rows

MU = 0.168                        # seed 002 Eq. 10
SWEEP = "2,4,8,12"
ANALYZE_FIELDS = {"run", "frequency_hz", "displacement_amplitude_m", "force_amplitude_n",
                  "energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m", "cycles"}


def _synthetic(rng, n_true=2.7, a=3e-7, rel=0.04, n=8):
    """Force amplitudes over a decade and W = a F^n with relative noise ``rel``."""
    F = np.geomspace(8.0, 90.0, n)
    rel_u = rel * rng.uniform(0.5, 1.5, n)             # uncertainties that differ per point
    W = a * F ** n_true * (1 + rel_u * rng.standard_normal(n))
    return F, W, rel_u * a * F ** n_true


def test_exponent_of_a_known_power_law_is_recovered_within_its_interval():
    rng = np.random.default_rng(1)
    F, W, u = _synthetic(rng)
    fit = fit_power_law(F, W, u, x_name="force_amplitude_n")
    lo, hi = fit.exponent_ci95
    assert lo < 2.7 < hi and hi - lo < 0.3
    assert fit.weighted and fit.n_amplitudes == 8 and fit.dof == 6
    assert fit.predict(30.0) == pytest.approx(3e-7 * 30.0 ** 2.7, rel=0.05)


def test_the_95_percent_interval_covers_the_true_exponent_about_95_percent_of_the_time():
    rng = np.random.default_rng(7)
    hits = []
    for _ in range(400):
        F, W, u = _synthetic(rng, n_true=2.5, n=5)
        lo, hi = fit_power_law(F, W, u).exponent_ci95
        hits.append(lo < 2.5 < hi)
    assert 0.93 <= np.mean(hits) <= 1.0


def test_weights_follow_the_stated_uncertainties():
    """One point far off the line but with a large stated uncertainty barely moves the
    weighted exponent; unweighted, it pulls it away."""
    F = np.array([5.0, 10.0, 20.0, 40.0, 80.0])
    W = 1e-6 * F ** 3.0
    W[4] *= 3.0
    u = 0.01 * W
    u[4] = 5.0 * W[4]
    assert abs(fit_power_law(F, W, u).exponent - 3.0) < 0.02
    unweighted = fit_power_law(F, W)
    assert not unweighted.weighted and abs(unweighted.exponent - 3.0) > 0.05


def test_fewer_than_three_distinct_amplitudes_are_refused_naming_the_axis():
    with pytest.raises(InputError) as e:
        fit_power_law([10.0, 10.02, 20.0, 20.0], [1.0, 1.1, 8.0, 8.2], x_name="force_amplitude_n")
    assert e.value.field == "force_amplitude_n"
    assert "2 distinct amplitudes" in e.value.message and "at least 3" in e.value.message
    with pytest.raises(InputError) as e:
        fit_power_law([1.0, 2.0, 4.0], [1.0, -2.0, 16.0], y_name="energy_loss_j")
    assert e.value.field == "energy_loss_j" and "positive" in e.value.message


def _simulate(out, *extra):
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["simulate", "--sweep", SWEEP, "--cycles", "20", "--sample-rate", "25000",
                   "--out", str(out), "--json", *extra])
    assert rc == 0, buf.getvalue()
    return sorted(str(p) for p in out.glob("*.h5"))


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """Run files of `labjoint simulate --sweep 2,4,8,12` on the default (seed 002) joint."""
    return _simulate(tmp_path_factory.mktemp("trend-sweep"))


@pytest.fixture(scope="module")
def dry_sweep(tmp_path_factory):
    """The same sweep with the dry micro-slip contact alone (no viscoelastic shear layer)."""
    from test_api_helpers import sim_config_file
    d = tmp_path_factory.mktemp("trend-dry")
    cfg = sim_config_file(d)
    cfg.write_text(cfg.read_text().replace("[sim]\n", '[sim]\njoint = "dry_microslip"\n', 1))
    return _simulate(d / "runs", "--config", str(cfg), "--sweep", "4,8,12,16,20")


def test_simulated_sweep_energy_loss_rises_with_amplitude_by_both_methods(sweep):
    body = build_trends(trend_rows(sweep, MU))
    rows = sorted(body["runs"], key=lambda r: r["excitation_vpp"])
    assert [r["excitation_vpp"] for r in rows] == [2.0, 4.0, 8.0, 12.0]
    for key in ("displacement_amplitude_m", "force_amplitude_n", "energy_loss_j",
                "stickslip_energy_loss_j"):
        assert np.all(np.diff([r[key] for r in rows]) > 0), key
    for r in rows:                                     # every plotted value has its bar
        for key in ("energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m",
                    "stickslip_energy_loss_j", "stickslip_damping_ns_per_m",
                    "displacement_amplitude_m", "force_amplitude_n"):
            u = r[key + "_uncertainty"]
            assert np.isfinite(u) and 0 < u < 0.2 * abs(r[key]), (key, u)
    # seed 002 Table 3 layout: by excitation, three properties a run, loop - model in %
    table = body["table"]
    assert table["conditions"] == ["excitation_vpp"] and body["varying"] == ["excitation_vpp"]
    assert [t["condition"]["excitation_vpp"] for t in table["rows"][::3]] == [2.0, 4.0, 8.0, 12.0]
    w = next(t for t in table["rows"] if t["property"] == "energy_loss_j")
    assert w["diff_pct"] == pytest.approx((w["loop"] - w["stickslip"]) / w["loop"] * 100)
    # the shear layer's nearly constant damping: W ~ F^2 (seed 002 Table 3's C is flat)
    fit = body["fit"]
    assert fit["error"] is None and (fit["method"], fit["against"]) == ("loop", "force_amplitude_n")
    lo, hi = fit["exponent_ci95"]
    assert 1.8 < lo <= fit["exponent"] <= hi < 2.3
    assert {(f["method"], f["against"]) for f in body["fits"]} == {
        (m, a) for m in ("loop", "stickslip")
        for a in ("excitation_vpp", "displacement_amplitude_m", "force_amplitude_n")}


def test_micro_slip_alone_dissipates_faster_than_the_square_of_the_force(dry_sweep):
    """Without the viscous shear layer, micro-slip's W rises faster than F^2 (seed 001:
    F^(3 + chi)); the fit tells the two joints apart beyond their intervals."""
    fit = build_trends(trend_rows(dry_sweep))["fit"]
    assert fit["error"] is None
    assert fit["exponent_ci95"][0] > 2.5


def _cli(args, capsys):
    rc = main(args)
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_analyze_table_prints_seed002_tables_and_the_exponent(sweep, capsys):
    rc, text, _ = _cli(["analyze", *sweep, "--table", "--friction", str(MU), "--quiet"], capsys)
    assert rc == 0
    rc, js, _ = _cli(["analyze", *sweep, "--table", "--friction", str(MU), "--json"], capsys)
    assert rc == 0
    out = json.loads(js)
    assert len(out["runs"]) == 4 and out["errors"] == []
    assert all(ANALYZE_FIELDS <= set(r) for r in out["runs"])   # design.md's contract kept
    fit = out["trend"]["fit"]
    m = re.search(r"n = ([\d.]+), 95 % CI \[([\d.]+), ([\d.]+)\]", text)
    assert m, text
    got = [float(x) for x in m.groups()]
    assert got == pytest.approx([fit["exponent"], *fit["exponent_ci95"]], rel=2e-3)
    lines = text.splitlines()
    assert "Stick-slip model" in lines[0] and "Hysteresis loop" in lines[0]
    by_vpp = {r["excitation_vpp"]: r for r in out["runs"]}
    for vpp, r in by_vpp.items():                   # W in mJ on the run's first line
        (line,) = [ln for ln in lines if ln.split()[:1] == [f"{vpp:.4g}"]]
        cells = line.split()
        assert "Energy loss (mJ)" in line
        assert float(cells[4]) == pytest.approx(r["stickslip_energy_loss_j"] * 1e3, rel=1e-3)
        assert float(cells[6]) == pytest.approx(r["energy_loss_j"] * 1e3, rel=1e-3)


def test_analyze_table_refuses_an_exponent_from_two_amplitudes_and_names_bad_files(
        sweep, tmp_path, capsys):
    missing = str(tmp_path / "missing.h5")
    rc, text, err = _cli(["analyze", sweep[0], missing, sweep[1], "--table", "--method", "loop",
                          "--quiet"], capsys)
    assert rc == 2                                   # an error, the good files still shown
    assert f"{missing}: no such file" in err
    assert "no dissipation exponent" in text and "2 distinct amplitudes" in text
    assert text.count("Energy loss (mJ)") == 2
    rc, js, _ = _cli(["analyze", sweep[0], sweep[1], "--table", "--method", "loop", "--json"],
                     capsys)
    fit = json.loads(js)["trend"]["fit"]
    assert rc == 0 and fit["exponent"] is None and "at least 3" in fit["error"]
