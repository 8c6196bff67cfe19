"""Model inputs: derivatives, priming, run data validation."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.models import Model, ModelInputs, RunData, derivatives, estimate_frequency
from labjoint.storage.run import Run

FS = 25600.0


@pytest.mark.parametrize("f", [50.0, 333.3, 1000.0])
def test_derivatives_exact_within_band_up_to_the_edges(f):
    t = np.arange(int(0.1 * FS) + 37) / FS
    w = 2 * np.pi * f
    u = 3e-6 + 1e-5 * np.sin(w * t + 0.4) + 2e-6 * np.sin(2 * w * t)
    v, a = derivatives(u, FS, frequency_hz=f)
    v_true = 1e-5 * w * np.cos(w * t + 0.4) + 4e-6 * w * np.cos(2 * w * t)
    a_true = -1e-5 * w * w * np.sin(w * t + 0.4) - 8e-6 * w * w * np.sin(2 * w * t)
    assert np.max(np.abs(v - v_true)) < 1e-4 * 1e-5 * w
    assert np.max(np.abs(a - a_true)) < 1e-3 * 1e-5 * w * w


def test_derivatives_suppress_noise_above_the_band():
    rng = np.random.default_rng(3)
    t = np.arange(8192) / FS
    w = 2 * np.pi * 100.0
    u = 1e-5 * np.sin(w * t)
    noise = rng.normal(0, 1e-8, t.size)
    v, _ = derivatives(u + noise, FS, frequency_hz=100.0)
    naive = np.gradient(u + noise, 1 / FS)
    v_true = 1e-5 * w * np.cos(w * t)
    err, err_naive = np.std(v - v_true), np.std(naive - v_true)
    assert err < 0.3 * err_naive


def test_frequency_estimate():
    t = np.arange(5000) / FS
    assert estimate_frequency(np.sin(2 * np.pi * 412.7 * t), FS) == pytest.approx(412.7, rel=1e-5)


def test_priming_makes_a_mid_cycle_record_steady_from_its_first_sample():
    """A record starting mid-steady-state (phase 1 rad): with priming, a Jenkins element is
    on its steady loop from sample 0 (closed form); without, it starts relaxed."""
    k, fs_, U, f = 2e7, 40.0, 10e-6, 100.0
    t = np.arange(int(3 * FS / f)) / FS
    ph = 2 * np.pi * f * t + 1.0
    u = U * np.sin(ph)
    # steady Jenkins loop between the sampled extremes: from -f_s at the minimum the
    # rising branch climbs with slope k to the +f_s plateau, and symmetrically
    rising = np.cos(ph) > 0
    lo, hi = u.min(), u.max()
    steady = np.where(rising, np.minimum(-fs_ + k * (u - lo), fs_), np.maximum(fs_ - k * (hi - u), -fs_))
    vals = {"coulomb.k": k, "coulomb.f_s": fs_}
    primed = ModelInputs.from_record(u, FS, frequency_hz=f, prime_cycles=1)
    assert primed.n_prime == int(FS / f) and len(primed) == u.size
    np.testing.assert_allclose(Model.parse("coulomb").eval(vals, primed), steady, atol=1e-6 * fs_)
    cold = Model.parse("coulomb").eval(vals, ModelInputs.from_record(u, FS, frequency_hz=f))
    assert cold[0] == 0.0 and np.max(np.abs(cold[:50] - steady[:50])) > 0.1 * fs_


def test_run_data_validation_names_the_field():
    u = np.sin(np.arange(1000) / 10.0)
    with pytest.raises(InputError, match="force"):
        RunData.from_arrays(u, u[:-1], FS)
    with pytest.raises(InputError, match="steady"):
        RunData.from_arrays(u, u, FS, steady=np.zeros(1000, bool))
    with pytest.raises(InputError, match="displacement"):
        RunData.from_arrays(np.r_[u[:-1], np.nan], u, FS)
    with pytest.raises(InputError, match="sample_rate_hz"):
        RunData.from_arrays(u, u, -1.0)
    rd = RunData.from_arrays(u, u, FS, steady=(100, 900))
    assert rd.steady.sum() == 800 and rd.steady[100] and not rd.steady[99]


def test_from_storage_run_uses_metadata():
    t = np.arange(2048) / FS
    u = 1e-5 * np.sin(2 * np.pi * 200.0 * t)
    run = Run("r1", t, u, 1e7 * u, metadata={"frequency_hz": 200.0, "sample_rate_hz": FS, "torque_nm": 5.0})
    rd = RunData.from_run(run, steady=slice(512, None))
    assert rd.name == "r1" and rd.frequency_hz == 200.0 and rd.inputs.metadata["torque_nm"] == 5.0
    np.testing.assert_allclose(rd.inputs.t, t)
