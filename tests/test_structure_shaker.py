"""The shaker in the structure model: responses per volt, identification from a linear test."""

import numpy as np
import pytest

from labjoint.acquisition.plans import step_sine
from labjoint.config import CONFIG_DIR
from labjoint.errors import InputError
from labjoint.signal.frf_steps import frfset_from_runs
from labjoint.structure import load_structure
from labjoint.structure.modal import modes
from labjoint.structure.shaker import Shaker, force_per_volt, identify_shaker, linear_accelerance, per_volt
from structure_runs import run_plans

TRUE = Shaker(0.3, 3.0e3, 5.0, 2.0, 6.0e-4, 4.0, 5.0)   # the simulated rig's shaker


@pytest.fixture(scope="module")
def structure():
    return load_structure(CONFIG_DIR / "structure-seed000.toml")


def test_coupled_solve_equals_the_closed_form(structure):
    f = np.array([15.0, 40.0, 41.0, 120.0, 231.0, 400.0])
    hd, hs = linear_accelerance(structure, f)
    r = per_volt(structure, TRUE, f)
    fv = force_per_volt(TRUE, f, hd)
    assert r["force_per_volt"] == pytest.approx(fv, rel=1e-9)
    assert r["acceleration_per_volt"] == pytest.approx(hs * fv[:, None], rel=1e-9)
    # at DC-like low frequency the coil sees no back-EMF: I = G V / R
    assert abs(per_volt(structure, TRUE, [0.01])["current_per_volt"][0]) == pytest.approx(5.0 / 2.0, rel=1e-3)
    # at the structure's own resonance the shaker cannot push: the force dips (seed 000's control problem)
    f1 = modes(structure, 1).frequencies_hz[0]
    hd1, _ = linear_accelerance(structure, [f1])
    assert abs(force_per_volt(TRUE, [f1], hd1)[0]) < 0.3 * abs(fv[0])


def test_identification_recovers_a_known_shaker(structure):
    f = np.geomspace(10.0, 500.0, 14)
    hd, _ = linear_accelerance(structure, f)
    s, misfit = identify_shaker(f, force_per_volt(TRUE, f, hd), hd, amplifier_gain_v_per_v=5.0)
    for k, v in TRUE.to_dict().items():
        assert getattr(s, k) == pytest.approx(v, rel=1e-6), k
    assert misfit < 1e-9
    with pytest.raises(InputError) as e:
        identify_shaker(f[:3], np.ones(3), np.ones(3))
    assert e.value.field == "frequencies_hz"
    with pytest.raises(InputError) as e:
        Shaker(0.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    assert e.value.field == "shaker.armature_mass_kg"    # the [shaker] table's field


def _sweep(freqs, level, d):
    (r,) = run_plans(d, [(step_sine(freqs, level, n_cycles=24, measure_cycles=8, directions=["up"],
                                    steady_tol=0.01, steady_window=20), "s")])
    assert r.status == "complete"
    return frfset_from_runs(sorted(d.glob("*.h5")), harmonics=1, segments=4)


def test_identified_shaker_predicts_the_rigs_response_per_volt(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    grid = sorted([float(f"{x:.4g}") for x in np.geomspace(12.0, 400.0, 8)] + [28.5, 190.0])
    test = _sweep(grid, 1.0, tmp_path / "a")                 # a linear (low-level) test
    drive = test.sensors.index("free_end")                    # the accelerometer at the drive point
    s, misfit = identify_shaker(test.frequencies_hz, test.force / test.drive_v,
                                test.accelerance()[:, drive], amplifier_gain_v_per_v=5.0)
    assert misfit < 0.01
    assert s.armature_mass_kg == pytest.approx(TRUE.armature_mass_kg, rel=0.05)
    # other frequencies, around mode 1: a per volt from the structure's a per newton and the shaker
    val = _sweep([27.75, 28.25, 28.75, 60.0], 1.0, tmp_path / "b")
    predicted = val.accelerance() * force_per_volt(s, val.frequencies_hz, val.accelerance()[:, drive])[:, None]
    measured = val.response[:, :, 0] / val.drive_v[:, None]
    assert np.abs(predicted / measured - 1).max() < 0.03


def test_harmonic_balance_with_the_shaker_coupled_in(structure):
    from labjoint.structure.modal import with_parameter
    from labjoint.structure.shaker import response_per_volt

    from frfdata import seed000_steel
    # seed 000's one-stiffness stage 1 (mode 1 near 28 Hz) with Table 4's law
    s = with_parameter(seed000_steel(structure), "E_e_pa", 2.2e7)
    f = np.array([27.0, 27.5, 28.0])
    lin = per_volt(s, TRUE, f)
    low = response_per_volt(s, TRUE, f, 1e-3, harmonics=1)
    # at a millivolt the joints stick: the reduced HBM equals the full linear coupled solve
    assert low["force_per_volt"][:, 0] == pytest.approx(lin["force_per_volt"], rel=1e-4)
    assert low["acceleration_per_volt"][:, :, 0] == pytest.approx(lin["acceleration_per_volt"], rel=1e-4)
    assert low["current_per_volt"][:, 0] == pytest.approx(lin["current_per_volt"], rel=1e-4)
    high = response_per_volt(s, TRUE, f, 20.0, harmonics=3)
    a_low, a_high = (np.abs(r["acceleration_per_volt"][:, -1, 0]) for r in (low, high))
    assert a_high.max() < 0.9 * a_low.max()              # the threads slip: less response per volt
    h2, h3 = (np.abs(high["acceleration_per_volt"][:, -1, k]).max() for k in (1, 2))
    assert h3 > 3e-4 * a_high.max() and h2 < 0.1 * h3   # symmetric hysteresis: odd harmonics only
    with pytest.raises(InputError) as e:
        response_per_volt(s, TRUE, f, 0.0)
    assert e.value.field == "volts"
