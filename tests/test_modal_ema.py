"""Natural frequency and damping of measured FRFs: LSCF/LSFD (sdypy-ema) and half-power."""

import numpy as np
import pytest

from labjoint.acquisition.plans import step_sine
from labjoint.errors import InputError
from labjoint.identify.modal import half_power, lscf, modal_parameters
from labjoint.signal.frf_steps import frfset_from_runs
from labjoint.signal.frfset import FrfSet
from structure_runs import run_plans


def _linear_set(fn=28.5, zeta=0.01, df=0.1, noise=0.0):
    f = np.arange(24.0, 33.0 + df / 2, df)
    w, wn, w2 = 2 * np.pi * f, 2 * np.pi * fn, 2 * np.pi * 180.0
    mode1 = 1.0 / (wn**2 - w**2 + 2j * zeta * wn * w)
    mode2 = 1.0 / (w2**2 - w**2 + 2j * 0.01 * w2 * w)   # a residual from the next mode
    rec = np.stack([0.08 * mode1 + 0.3 * mode2, 0.45 * mode1 - 0.4 * mode2], 1) * -(w**2)[:, None]
    rng = np.random.default_rng(0)
    rec = rec * (1 + noise * (rng.standard_normal(rec.shape) + 1j * rng.standard_normal(rec.shape)))
    force = np.full(f.size, 10.0 + 0j)
    return FrfSet(f, np.full(f.size, 10.0), ["up"] * f.size, force, ("a", "b"),
                  (rec * force[:, None])[:, :, None], np.zeros((f.size, 2, 1)))


def test_both_methods_recover_a_linear_mode():
    (g,) = modal_parameters(_linear_set(noise=0.002))
    assert g["lscf"]["natural_frequency_hz"] == pytest.approx(28.5, rel=1e-3)
    assert g["lscf"]["damping_ratio"] == pytest.approx(0.01, rel=0.05)
    assert g["half_power"]["natural_frequency_hz"] == pytest.approx(28.5, rel=2e-3)
    assert g["half_power"]["damping_ratio"] == pytest.approx(0.01, rel=0.05)
    assert g["sensor"] == "b"
    # LSFD modal constants: the two sensors' residues in the ratio of the mode's shape (0.08 : 0.45)
    a, b = (complex(*c) for c in g["lscf"]["modal_constants"])
    assert abs(a / b) == pytest.approx(0.08 / 0.45, rel=0.05)


def test_uneven_grid_and_bad_input():
    s = _linear_set(df=0.05)
    keep = np.r_[0:60:3, 60:s.frequencies_hz.size]   # coarse below, fine above
    r = lscf(s.frequencies_hz[keep], s.accelerance()[keep].T)
    assert r["natural_frequency_hz"] == pytest.approx(28.5, rel=2e-3)
    _, z = half_power([27.0, 28.0, 29.0], [1.0, 3.0, 1.0])   # half-power points off the band
    assert np.isnan(z) or z > 0
    with pytest.raises(InputError) as e:
        modal_parameters(s, sensor="nowhere")
    assert e.value.field == "sensor"
    with pytest.raises(InputError) as e:
        lscf([1.0, 2.0], [[1.0, 2.0]])
    assert e.value.field == "frequencies_hz"


def test_lowest_level_of_the_structural_rig(tmp_path):
    freqs = [float(x) for x in np.arange(27.5, 29.76, 0.25)]
    (r,) = run_plans(tmp_path, [(step_sine(freqs, 0.5, n_cycles=24, measure_cycles=8,
                                           directions=["up"], steady_max_cycles=300,
                                           steady_tol=0.003, steady_window=20), "low")])
    assert r.status == "complete"
    (g,) = modal_parameters(frfset_from_runs(sorted(tmp_path.glob("*.h5")), harmonics=1, segments=4))
    # the truth: mode 1 near 28.5 Hz, modal damping 0.4 % (of the modes with the armature) plus micro-slip
    assert g["lscf"]["natural_frequency_hz"] == pytest.approx(28.6, abs=0.3)
    assert 0.0035 <= g["lscf"]["damping_ratio"] < 0.008
    assert g["half_power"]["natural_frequency_hz"] == pytest.approx(g["lscf"]["natural_frequency_hz"], rel=0.01)
