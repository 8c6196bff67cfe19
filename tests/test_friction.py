"""Identified inputs of the stick-slip method: friction coefficient (seed 002 Eq. 10),
shear-layer stiffness from the loop slope (Eq. 9), and where they are kept."""

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.identify.friction import (friction_coefficient, identify_friction, loop_stiffness,
                                        normal_force, shear_layer_stiffness, sliding_force)
from labjoint.identify.identified import Identified, load_identified, save_identified
from labjoint.signal.filter import lowpass
from labjoint.storage import read_run

FS, F = 50_000.0, 100.0


def jenkins(u, k, f_s):
    """Spring k in series with a Coulomb slider of strength f_s."""
    out = np.empty_like(u)
    force, prev = 0.0, u[0]
    for i, x in enumerate(u):
        force = min(max(force + k * (x - prev), -f_s), f_s)
        prev = x
        out[i] = force
    return out


def _loop(U, f_s=160.0, k=12e6, c=0.0, offset=0.0, noise=0.0, seconds=0.2):
    t = np.arange(int(seconds * FS)) / FS
    u = U * np.sin(2 * np.pi * F * t)
    v = U * 2 * np.pi * F * np.cos(2 * np.pi * F * t)
    f = jenkins(u, k, f_s) + c * v + offset
    f += noise * np.random.default_rng(0).standard_normal(t.size)
    return lowpass(u, FS), lowpass(f, FS)


def test_sliding_force_is_read_at_the_plateau_end_free_of_viscous_force_and_offset():
    u, f = _loop(60e-6, c=300.0, offset=4.0, noise=0.3)
    f_sld, sem, info = sliding_force(u, f, FS, F)
    assert f_sld == pytest.approx(160.0, rel=2e-3)
    assert abs(f_sld - 160.0) <= sem < 1.0 and info["slip_fraction"] > 0.5   # covers its error
    assert info["plateau_viscous_ns_per_m"] == pytest.approx(300.0, rel=0.05)
    assert info["offset_n"] == pytest.approx(4.0, abs=0.2)
    assert info["plateau_mean_n"] > 165.0          # the viscous force rides on the plateau


def test_friction_coefficient_is_sliding_over_normal_force_eq10():
    u, f = _loop(40e-6)
    n = 956.3
    mu = friction_coefficient(u, f, FS, F, n, source="t", normal_force_rel_uncertainty=0.02)
    assert mu.value == pytest.approx(160.0 / n, rel=2e-3)
    assert mu.uncertainty == pytest.approx(0.02 * mu.value, rel=0.05)   # dominated by N
    assert mu.source == "t" and mu.n_cycles >= 15


def test_microslip_loop_is_refused_as_a_friction_test():
    u, f = _loop(8e-6)                              # f_s / k = 13 um: never slides
    with pytest.raises(InputError) as exc:
        friction_coefficient(u, f, FS, F, 956.3)
    assert exc.value.field == "force" and "macro-slip" in str(exc.value)


def test_shear_layer_stiffness_is_half_the_loop_slope():
    t = np.arange(int(0.1 * FS)) / FS
    w = 2 * np.pi * 400.0
    u = 5e-6 * np.sin(w * t)
    k, c = 11.8e6, 1800.0
    f = k * u + c * 5e-6 * w * np.cos(w * t)
    kt = shear_layer_stiffness(u, f, FS, 400.0, source="r")
    assert kt.value == pytest.approx(k / 2, rel=1e-6)             # least squares: k
    ks, amp = loop_stiffness(u, f, FS, 400.0, "secant")
    assert np.allclose(ks, np.hypot(k, c * w), rtol=1e-3)          # |k + i c w|
    assert np.allclose(amp, 5e-6, rtol=1e-3)
    with pytest.raises(InputError) as exc:
        loop_stiffness(u, f, FS, 400.0, "tangent")
    assert exc.value.field == "stiffness_method"


def test_normal_force_from_torque_and_bad_values():
    assert normal_force(2.0) == pytest.approx(956.0)               # seed 002: 478 N/Nm
    for bad, field in ((0.0, "torque_nm"), (-1.0, "torque_nm")):
        with pytest.raises(InputError) as exc:
            normal_force(bad)
        assert exc.value.field == field
    with pytest.raises(InputError) as exc:
        normal_force(2.0, 0.0)
    assert exc.value.field == "torque_to_normal_n_per_nm"
    u, f = _loop(40e-6)
    with pytest.raises(InputError) as exc:
        friction_coefficient(u, f, FS, F, 0.0)
    assert exc.value.field == "normal_force_n"


def test_identified_values_are_kept_with_their_source(tmp_path):
    assert load_identified(tmp_path, "friction_coefficient") is None
    a = Identified("friction_coefficient", 0.17, 0.002, "1", "run-a", "Eq. 10")
    b = Identified("friction_coefficient", 0.16, 0.001, "1", "run-b", "Eq. 10")
    save_identified(tmp_path, a)
    save_identified(tmp_path, b)
    got = load_identified(tmp_path, "friction_coefficient")
    assert (got.value, got.uncertainty, got.source) == (0.16, 0.001, "run-b")
    (tmp_path / "identified.json").write_text("{not json")
    with pytest.raises(InputError) as exc:
        load_identified(tmp_path, "friction_coefficient")
    assert "identified.json" in str(exc.value)


def test_friction_test_on_the_simulated_rig_recovers_mu_within_5_percent(tmp_path):
    from test_stickslip_simrig import MU_SIM, write_sim_run
    # seed 002 IV.A: 100 Hz, 2 Nm, macro-slip
    path = write_sim_run(tmp_path, "friction", 100.0, 20.0, 2.0, seconds=0.3)
    mu = identify_friction(read_run(path))
    assert mu.value == pytest.approx(MU_SIM, rel=0.05)
    assert mu.source == "friction" and mu.details["normal_force_n"] == pytest.approx(956.0)
    # the reference condition (400 Hz, 5 Nm) is micro-slip: refused, not mis-identified
    ref = write_sim_run(tmp_path, "reference", 400.0, 20.0, 5.0, seconds=0.1)
    with pytest.raises(InputError):
        identify_friction(read_run(ref))


def _shelf(x, fs, f_ref=F, shelf_hz=8.0, ratio=0.6):
    """A film sensor's low-frequency roll-off (s + ratio w)/(s + w), unity gain at f_ref."""
    from scipy import signal as sps

    w = 2 * np.pi * shelf_hz
    b, a = sps.bilinear([1.0, ratio * w], [1.0, w], fs)
    g = abs(sps.freqz(b, a, worN=[f_ref], fs=fs)[1][0])
    return sps.lfilter(b / g, a, x)


def test_plateau_level_is_free_of_the_sensor_droop():
    # A Jenkins joint (f_s = 160 N) seen through a sensor whose roll-off makes every
    # plateau droop by a few newtons: the tip reading is biased, the plateau fit is not.
    u, f = _loop(60e-6, seconds=1.0)
    sensed = _shelf(f, FS)[int(0.5 * FS):]                  # periodic steady state
    u = u[int(0.5 * FS):]
    f_sld, sem, info = sliding_force(u, sensed, FS, F)
    assert abs(info["tip_force_n"] - 160.0) > 1.6             # > 1 % off at the tips
    assert f_sld == pytest.approx(160.0, rel=3e-3)            # the viscous term is always fitted
    assert abs(f_sld - 160.0) <= sem                          # and the uncertainty says so
    assert info["sensor_lag_per_s"] > 0


@pytest.mark.parametrize("torque", [1.0, 1.5, 2.0])
def test_friction_coefficient_on_the_simulated_rig_within_one_percent(tmp_path, torque):
    from test_stickslip_simrig import MU_SIM, write_sim_run
    # seed 002 IV.A: 100 Hz, low torque, macro-slip; the film sensor's droop is fitted out
    path = write_sim_run(tmp_path, f"friction_{torque}", 100.0, 20.0, torque, seconds=0.3)
    mu = identify_friction(read_run(path))
    assert mu.value == pytest.approx(MU_SIM, rel=0.01)
