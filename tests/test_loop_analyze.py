"""The streamed hysteresis-loop pipeline end to end (seed 002 Sec. IV.A)."""

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.identify.analyze import analyze_arrays, analyze_blocks, analyze_run
from labjoint.storage.run import Run
from test_loop import jenkins

FS, F0 = 50_000.0, 400.0
OMEGA = 2 * np.pi * F0
SUMMARY_KEYS = {"frequency_hz", "displacement_amplitude_m", "force_amplitude_n",
                "energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m",
                "stiffness_secant_n_per_m", "stiffness_lsq_n_per_m", "cycles"}
RESOLUTION_KEYS = {"energy_loss_j_uncertainty", "energy_loss_j_resolution",
                   "energy_loss_j_uncertainty_phase", "below_resolution",
                   "cycles_below_resolution", "damping_ns_per_m_uncertainty"}


def viscous_record(seconds=1.0, U=8e-6, k=1.2e7, c=1800.0, tau=None, noise=0.005,
                   drift=0.0, seed=0, fs=FS):
    t = np.arange(int(seconds * fs)) / fs
    env = np.ones_like(t) if tau is None else 1 - np.exp(-t / tau)
    denv = np.zeros_like(t) if tau is None else np.exp(-t / tau) / tau
    env, denv = env * (1 - drift * t / seconds), denv * (1 - drift * t / seconds) - env * drift / seconds
    u = U * env * np.sin(OMEGA * t)
    du = U * (env * OMEGA * np.cos(OMEGA * t) + denv * np.sin(OMEGA * t))
    F = k * u + c * du
    rng = np.random.default_rng(seed)
    return u + noise * U * rng.standard_normal(t.size), F + noise * k * U * rng.standard_normal(t.size)


def test_viscous_record_gives_c_and_k():
    u, F = viscous_record()
    r = analyze_arrays(u, F, FS, F0)
    s = r.summary
    assert set(s) == (SUMMARY_KEYS | {key + "_std" for key in SUMMARY_KEYS - {"cycles"}}
                      | RESOLUTION_KEYS)
    assert s["below_resolution"] is False
    assert s["damping_ns_per_m"] == pytest.approx(1800.0, rel=3e-3)
    assert s["energy_loss_j"] == pytest.approx(np.pi * 1800.0 * OMEGA * 8e-6 ** 2, rel=3e-3)
    assert s["stiffness_n_per_m"] == s["stiffness_lsq_n_per_m"] == pytest.approx(1.2e7, rel=2e-3)
    assert s["stiffness_secant_n_per_m"] == pytest.approx(np.hypot(1.2e7, 1800 * OMEGA), rel=3e-3)
    assert s["displacement_amplitude_m"] == pytest.approx(8e-6, rel=2e-3)
    assert s["cycles"] >= 395 and r.steady_state.start == 0
    assert 0 < s["damping_ns_per_m_std"] < 0.05 * 1800
    assert r.metadata["cutoff_hz"] == 3000.0 and r.metadata["stiffness_estimator"] == "lsq"


@pytest.mark.parametrize("cutoff", [3000.0, None])
def test_jenkins_record_with_offsets_matches_closed_form(cutoff):
    t = np.arange(int(0.5 * FS)) / FS
    U, k, f_s = 10e-6, 1.2e7, 60.0
    u = U * np.sin(OMEGA * t)
    F = jenkins(u, k, f_s)
    r = analyze_arrays(u + 2e-4, F + 15.0, FS, F0, cutoff)  # DC offsets: removed / irrelevant
    assert r.summary["energy_loss_j"] == pytest.approx(4 * f_s * (U - f_s / k), rel=1e-3)
    assert r.summary["cycles"] >= 195


def test_start_from_rest_drops_the_settling_cycles():
    tau_cycles = 10.0
    u, F = viscous_record(seconds=1.0, tau=tau_cycles / F0, noise=0.001)
    r = analyze_arrays(u, F, FS, F0)
    # cycle k (from the boundary at ~k+1 periods) is within 1 % once exp(-(k+1.5)/tau) < 1 %
    expected = tau_cycles * np.log(100) - 1.5
    assert abs(r.steady_state.start - expected) <= 2.5
    assert r.summary["damping_ns_per_m"] == pytest.approx(1800.0, rel=3e-3)


def test_slow_drift_is_kept():
    u, F = viscous_record(seconds=1.0, drift=0.15, noise=0.002)
    r = analyze_arrays(u, F, FS, F0)
    assert r.steady_state.start <= 1 and r.summary["cycles"] >= r.n_cycles - 2


def test_chunked_equals_in_memory():
    u, F = viscous_record(seconds=0.6, tau=0.01)
    whole = analyze_blocks([(u, F)], FS, F0)
    rng = np.random.default_rng(5)
    cuts = np.sort(rng.choice(np.arange(1, u.size), 40, replace=False))
    blocks = [np.stack([a, b]) for a, b in zip(np.split(u, cuts), np.split(F, cuts))]
    chunked = analyze_blocks(iter(blocks), FS, F0)
    assert chunked.n_cycles == whole.n_cycles
    assert np.allclose(chunked.bounds, whole.bounds, rtol=0, atol=1e-6)
    for name in ("energy_loss", "damping", "stiffness_lsq", "stiffness_secant"):
        assert np.allclose(getattr(chunked, name), getattr(whole, name), rtol=1e-8, atol=0)
    assert np.array_equal(chunked.steady, whole.steady)
    for key, value in whole.summary.items():
        assert chunked.summary[key] == pytest.approx(value, rel=1e-8)


def test_frequency_estimated_when_not_given():
    u, F = viscous_record(seconds=1.5)
    r = analyze_arrays(u, F, FS)
    assert r.frequency_hz == pytest.approx(F0, rel=1e-5)
    assert r.metadata["frequency_source"].startswith("estimated")
    assert r.summary["damping_ns_per_m"] == pytest.approx(1800.0, rel=3e-3)


def test_analyze_run_uses_metadata():
    u, F = viscous_record(seconds=0.5)
    t = np.arange(u.size) / FS
    run = Run("r1", t, u, F, metadata={"frequency_hz": F0, "sample_rate_hz": FS})
    r = analyze_run(run)
    assert r.metadata["run"] == "r1" and r.metadata["frequency_source"] == "given"
    assert r.summary["damping_ns_per_m"] == pytest.approx(1800.0, rel=3e-3)


def test_low_sample_rate_lowers_the_cutoff_and_says_so():
    u, F = viscous_record(seconds=1.0, fs=5000.0)
    r = analyze_arrays(u, F, 5000.0, F0)
    assert r.metadata["cutoff_hz"] == pytest.approx(2250.0)
    assert "0.45" in r.metadata["cutoff_rule"]
    assert r.summary["damping_ns_per_m"] == pytest.approx(1800.0, rel=2e-2)


@pytest.mark.parametrize("mutate, field", [
    (lambda u, F: (u, F[:-1]), "force"),
    (lambda u, F: (np.where(np.arange(u.size) == 99, np.nan, u), F), "displacement"),
    (lambda u, F: (u[:200], F[:200]), "displacement"),          # under 2 cycles
])
def test_bad_arrays_name_the_parameter(mutate, field):
    u, F = viscous_record(seconds=0.1)
    with pytest.raises(InputError, match=f"'{field}'"):
        analyze_arrays(*mutate(u, F), FS, F0)


@pytest.mark.parametrize("kwargs, field", [
    ({"fs": 0.0}, "fs"), ({"fs": -1.0}, "fs"), ({"frequency_hz": -4.0}, "frequency_hz"),
    ({"cutoff_hz": 300.0}, "cutoff_hz"), ({"min_cycles": 0}, "min_cycles"),
])
def test_bad_parameters_name_the_parameter(kwargs, field):
    u, F = viscous_record(seconds=0.1)
    args = {"fs": FS, "frequency_hz": F0, **kwargs}
    with pytest.raises(InputError, match=f"'{field}'"):
        analyze_arrays(u, F, **args)


def test_bad_blocks_name_the_block():
    u, F = viscous_record(seconds=0.1)
    with pytest.raises(InputError, match=r"blocks\[1\]"):
        analyze_blocks([(u, F), np.zeros((3, 10))], FS, F0)
    with pytest.raises(InputError, match=r"blocks\[0\].force"):
        analyze_blocks([(u, F[:-3])], FS, F0)
    with pytest.raises(InputError, match="'blocks'"):
        analyze_blocks([], FS)


def test_silence_before_the_excitation_is_not_steady():
    t = np.arange(int(FS)) / FS
    on = t >= 0.2                                          # 80 periods of digital zeros
    u = np.where(on, 8e-6 * np.sin(OMEGA * t), 0.0)
    F = np.where(on, 1.2e7 * u + 1800.0 * 8e-6 * OMEGA * np.cos(OMEGA * t), 0.0)
    r = analyze_arrays(u, F, FS, F0)
    first = r.bounds[:-1][r.steady][0]
    assert first >= 0.2 * FS - 1
    assert r.summary["damping_ns_per_m"] == pytest.approx(1800.0, rel=1e-3)
