"""The shaker between voltage and structure (issue 29 item 3), against an independent
generator: scipy's solve_ivp of a coil + armature coupled to a 2-DOF structure, written
here, driven by a multisine voltage; FRFs by the DFT of its last whole period."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from labjoint.errors import InputError
from labjoint.models.shaker import Shaker, force_on_structure, shaker_table
from labjoint.models.shaker_fit import identify

BL, R, L, G = 8.0, 2.0, 2.0e-3, 1.0          # coil corner R / (2 pi L) = 159 Hz: inside the band
MA, KA, CA = 0.05, 2.0e3, 3.0
M = np.diag([1.0, 0.5])
K = np.array([[2e4 + 3e4, -3e4], [-3e4, 3e4]])
C = 0.5 * M + 4e-5 * K                        # proportional: real modes, as M1 takes them
FS, T = 1024.0, 1.0
LINES = np.unique(np.round(np.geomspace(5, 300, 36)))
MT_INV = np.linalg.inv(M + np.diag([MA, 0.0]))   # the armature rides on DOF 1
ARMATURE = {"armature_mass_kg": MA, "suspension_stiffness_n_per_m": KA, "suspension_damping_ns_per_m": CA}


def _volts(t):
    ph = np.linspace(0, np.pi, LINES.size) ** 2                       # Schroeder-like phases
    return 0.5 * np.cos(2 * np.pi * np.multiply.outer(t, LINES) + ph).sum(-1)


def _rhs(t, y):
    x, v, i = y[:2], y[2:4], y[4]
    a = MT_INV @ (np.array([BL * i - CA * v[0] - KA * x[0], 0.0]) - C @ v - K @ x)
    di = (G * _volts(t) - R * i - BL * v[0]) / L
    return np.r_[v, a, di]


def _accelerations(t, y):
    """(2, n) accelerations of states (5, n) at times t (the generator's own equations)."""
    f = np.vstack([BL * y[4] - CA * y[2] - KA * y[0], np.zeros_like(t)])
    return MT_INV @ (f - C @ y[2:4] - K @ y[:2])


@pytest.fixture(scope="module")
def test_record():
    periods = 2                                   # the back-EMF damps the start-up within a period
    t = np.arange(int(periods * T * FS)) / FS
    sol = solve_ivp(_rhs, (0, t[-1]), np.zeros(5), t_eval=t, rtol=1e-7, atol=1e-12, method="DOP853",
                    dense_output=True)
    y = sol.y
    acc = _accelerations(t, y)
    force = BL * y[4] - MA * acc[0] - CA * y[2] - KA * y[0]
    last = slice(int((periods - 1) * T * FS), None)
    k = (LINES * T).astype(int)
    dft = lambda s: np.fft.rfft(s[last])[k]                          # noqa: E731
    U = dft(_volts(t))
    return {"sol": sol, "U": U, "a1": dft(acc[0]) / U, "v2": dft(y[3]) / U, "F": dft(force) / U}


def _structure_frf(f, row):
    w = 2 * np.pi * np.asarray(f)
    return np.array([np.linalg.solve(K - ww**2 * M + 1j * ww * C, [1.0, 0.0])[row] for ww in w])


def test_force_in_time_from_the_armature_equation(test_record):
    r = test_record
    sh = Shaker(MA, KA, CA, R, L, BL, G)
    fs = 16 * FS                                   # the coil's drive linear between samples (S1's hold)
    t = np.arange(int(0.5 * fs)) / fs
    y = r["sol"].sol(t)
    a = _accelerations(t, y)
    F, i = force_on_structure(sh, _volts(t), fs, y[0], y[2], a[0])
    force = BL * y[4] - MA * a[0] - CA * y[2] - KA * y[0]
    n = t.size // 5                                # the generator starts with the current at rest too
    assert np.max(np.abs(i - y[4])) < 2e-3 * np.max(np.abs(y[4]))
    assert np.sqrt(np.mean((F[n:] - force[n:]) ** 2)) < 2e-3 * np.std(force)


def test_with_force_every_shaker_parameter_and_the_structure(test_record):
    r = test_record
    fit = identify(LINES, {"a1": r["a1"], "v2": r["v2"]}, "a1",
                   quantities={"a1": "acceleration", "v2": "velocity"}, force_per_volt_measured=r["F"], n_modes=2)
    s = fit.shaker
    for got, want in [(s.force_factor_n_per_a, BL), (s.coil_resistance_ohm, R), (s.coil_inductance_h, L),
                      (s.armature_mass_kg, MA), (s.suspension_stiffness_n_per_m, KA)]:
        assert got == pytest.approx(want, rel=0.03)
    pn = fit.per_newton(LINES)
    w = 2 * np.pi * LINES
    want = {"a1": -(w**2) * _structure_frf(LINES, 0), "v2": 1j * w * _structure_frf(LINES, 1)}
    for k in want:
        assert np.max(np.abs(pn[k] - want[k]) / np.abs(want[k])) < 0.03
    pv = fit.per_volt(LINES)
    assert np.max(np.abs(pv["a1"] / r["a1"] - 1)) < 0.03
    assert fit.force_measured and fit.misfit < 0.01


@pytest.mark.parametrize("given, found", [
    ({"force_factor_n_per_a": BL, "coil_resistance_ohm": R}, ("coil_inductance_h", L)),
    ({"coil_resistance_ohm": R, "mode1.mass_kg": None}, ("force_factor_n_per_a", BL)),
])
def test_voltage_only_with_the_armature_and_two_scales_given(test_record, given, found):
    r = test_record
    lam, vec = np.linalg.eig(np.linalg.solve(M, K))
    order = np.argsort(lam.real)
    phi = vec[:, order[0]].real
    if "mode1.mass_kg" in given:                  # mode 1's modal mass seen at the drive point
        given = {**given, "mode1.mass_kg": float(phi @ M @ phi / phi[0] ** 2)}
    fit = identify(LINES, {"a1": r["a1"], "v2": r["v2"]}, "a1", quantities={"a1": "acceleration", "v2": "velocity"},
                   given={**ARMATURE, **given}, n_modes=2)
    name, want = found
    assert getattr(fit.shaker, name) == pytest.approx(want, rel=0.03)
    assert f"shaker.{name}" in fit.identified and "shaker.coil_resistance_ohm" in fit.given
    pn = fit.per_newton(LINES)
    w = 2 * np.pi * LINES
    for key, row, d in (("a1", 0, 2), ("v2", 1, 1)):
        want = (1j * w) ** d * _structure_frf(LINES, row)
        assert np.max(np.abs(pn[key] - want) / np.abs(want)) < 0.03
    # the structure's own modes (the armature not in them)
    assert fit.structure.frequencies_hz == pytest.approx(np.sqrt(lam.real[order]) / (2 * np.pi), rel=0.01)


def test_voltage_only_refuses_what_it_cannot_see(test_record):
    r = test_record
    resp, q = {"a1": r["a1"], "v2": r["v2"]}, {"a1": "acceleration", "v2": "velocity"}
    with pytest.raises(InputError, match="armature_mass_kg.*not identifiable.*give it") as e:
        identify(LINES, resp, "a1", quantities=q, n_modes=2)
    assert e.value.field == "shaker.armature_mass_kg"
    for given, name in (({}, "force_factor_n_per_a"), ({"force_factor_n_per_a": BL}, "coil_resistance_ohm"),
                        ({"coil_resistance_ohm": R, "coil_inductance_h": L}, "force_factor_n_per_a")):
        with pytest.raises(InputError, match=rf"shaker parameter {name} \(\w+\) not identifiable.*give it") as e:
            identify(LINES, resp, "a1", quantities=q, given={**ARMATURE, **given}, n_modes=2)
        assert e.value.field == f"shaker.{name}"


def test_shaker_table(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("[shaker]\nforce_factor_n_per_a = 8.0\ncoil_resistance_ohm = 2.0\n")
    assert shaker_table(p) == {"force_factor_n_per_a": 8.0, "coil_resistance_ohm": 2.0}
    p.write_text("[shaker]\nforce_constant = 8.0\n")
    with pytest.raises(InputError, match="unknown shaker parameter") as e:
        shaker_table(p)
    assert e.value.field == "shaker.force_constant" and e.value.file == str(p)
    p.write_text("[shaker]\ncoil_resistance_ohm = -2.0\n")
    with pytest.raises(InputError, match="positive"):
        shaker_table(p)


def test_cli_shaker_on_frf_sets(test_record, tmp_path, capsys):
    """`labjoint shaker FRF.json --drive a1`: from a force-driven set with the voltage beside
    (everything), and from a voltage-driven set with the [shaker] table's known parts."""
    import json

    from labjoint.cli.main import main
    from labjoint.signal.frfset import FrfSet

    r = test_record
    n = LINES.size
    resp = np.stack([r["a1"], r["v2"] * 2j * np.pi * LINES], 1)[:, :, None]      # both as acceleration
    common = dict(frequencies_hz=LINES, direction=["up"] * n, sensors=("a1", "a2"),
                  response_std=np.full(resp.shape, 1e-9), quantity="acceleration")
    with_force = tmp_path / "force.json"
    FrfSet(level_n=np.full(n, 1.0), force=r["F"], response=resp, drive_v=np.ones(n, complex),
           **common).save(with_force)
    assert main(["shaker", str(with_force), "--drive", "a1", "--modes", "2", "--json", "--full"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["force_measured"] and res["shaker"]["force_factor_n_per_a"] == pytest.approx(BL, rel=0.03)
    pn = np.array(res["per_newton"]["a1"]["re"]) + 1j * np.array(res["per_newton"]["a1"]["im"])
    want = -((2 * np.pi * LINES) ** 2) * _structure_frf(LINES, 0)
    assert np.max(np.abs(pn / want - 1)) < 0.03 and res["units"]["per_newton"] == "m/s^2/N"
    pf = np.array(res["per_volt"]["force"]["re"]) + 1j * np.array(res["per_volt"]["force"]["im"])
    assert np.max(np.abs(pf / r["F"] - 1)) < 0.03
    volts = tmp_path / "volts.json"
    FrfSet(level_n=np.full(n, 0.5), force=np.ones(n, complex), response=resp, drive_quantity="voltage",
           **common).save(volts)
    given = tmp_path / "s.toml"
    given.write_text("[shaker]\n" + "".join(f"{k} = {v!r}\n" for k, v in
                                            {**ARMATURE, "force_factor_n_per_a": BL, "coil_resistance_ohm": R}.items()))
    assert main(["shaker", str(volts), "--drive", "a1", "--modes", "2", "--given", str(given), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["shaker"]["coil_inductance_h"] == pytest.approx(L, rel=0.03)
    assert res["parameters"]["shaker.coil_resistance_ohm"]["given"]
    given.write_text("[shaker]\n" + "".join(f"{k} = {v!r}\n" for k, v in ARMATURE.items()))
    assert main(["shaker", str(volts), "--drive", "a1", "--modes", "2", "--given", str(given), "--json"]) == 2
    err = capsys.readouterr()
    assert err.out == "" and "force_factor_n_per_a (Bl) not identifiable" in err.err
