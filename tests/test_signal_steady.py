"""Steady-state detection on per-cycle amplitude series."""

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.signal.steady import detect_steady

K = np.arange(2000)


def _noise(scale, seed=0, n=K.size):
    return scale * np.random.default_rng(seed).standard_normal(n)


@pytest.mark.parametrize("tau", [5.0, 10.0, 25.0])
def test_exponential_settling_found_within_two_cycles(tau):
    a = 3e-6 * (1 - np.exp(-K / tau)) * (1 + _noise(5e-4))
    f = 40.0 * (1 - 0.7 * np.exp(-K / tau)) * (1 + _noise(5e-4, 1))
    expected = int(np.ceil(tau * np.log(100)))          # |a - a_inf| < 1 % from here
    s = detect_steady(a, f)
    assert abs(s.start - expected) <= 2
    assert s.stop == K.size


def test_already_steady_drops_nothing():
    a = 5e-6 * (1 + _noise(3e-3))
    f = 60.0 * (1 + _noise(3e-3, 1))
    ph = 0.2 + _noise(2e-3, 2)
    s = detect_steady(a, f, ph)
    assert (s.start, s.stop, s.n_steady) == (0, K.size, K.size)


@pytest.mark.parametrize("shape", ["linear", "exponential"])
def test_slow_monotone_drift_is_not_transient(shape):
    x = K / K.size
    drift = 1 - 0.15 * x if shape == "linear" else np.exp(-0.3 * x)   # 15-26 % over the run
    a = 5e-6 * drift * (1 + _noise(2e-3))
    f = 60.0 * drift ** 1.2 * (1 + _noise(2e-3, 1))
    s = detect_steady(a, f)
    assert s.start <= 1 and s.stop == K.size and s.n_steady >= K.size - 1


def test_fast_settling_then_slow_drift():
    a = 5e-6 * (1 - np.exp(-K / 8.0)) * (1 - 0.2 * K / K.size) * (1 + _noise(5e-4))
    s = detect_steady(a)
    assert abs(s.start - int(np.ceil(8.0 * np.log(100)))) <= 2
    assert s.stop == K.size


def test_ramp_up_plateau_ramp_down():
    a = np.minimum(np.minimum(K / 200.0, 1.0), (K.size - K) / 150.0) * (1 + _noise(1e-3))
    s = detect_steady(a)
    assert 198 <= s.start <= 202
    assert K.size - 152 <= s.stop <= K.size - 148


def test_noise_sets_the_tolerance_when_larger_than_rel_tol():
    # 2 % scatter per cycle with rel_tol 1 %: a noisy steady run is still steady
    a = 5e-6 * (1 + _noise(0.02))
    s = detect_steady(a, rel_tol=0.01)
    assert s.start == 0 and s.stop == K.size
    assert s.noise["displacement_amplitude"] == pytest.approx(1e-7, rel=0.15)


def test_isolated_glitch_does_not_split_the_run_but_is_dropped():
    a = 5e-6 * (1 + _noise(1e-3))
    a[1000] *= 1.3
    s = detect_steady(a)
    assert (s.start, s.stop) == (0, K.size)
    assert not s.mask[1000] and s.n_steady == K.size - 1


def test_phase_change_is_transient_even_at_constant_amplitude():
    a = np.full(K.size, 5e-6)
    ph = 0.3 - 0.2 * np.exp(-K / 10.0)
    s = detect_steady(a, None, ph)
    assert abs(s.start - int(np.ceil(10 * np.log(0.2 / 0.01)))) <= 2


def test_invalid_cycles_are_never_steady():
    a = 5e-6 * (1 + _noise(1e-3))
    valid = np.ones(K.size, bool)
    valid[:30] = False
    s = detect_steady(a, valid=valid)
    assert s.start == 30 and not s.mask[:30].any()


def test_too_few_cycles_keeps_all_and_says_so():
    s = detect_steady(np.array([1.0, 1.1, 0.9, 1.0, 1.05]))
    assert s.n_steady == 5 and "too few" in s.note


@pytest.mark.parametrize("kwargs, field", [
    ({"force_amplitude": np.ones(3)}, "force_amplitude"),
    ({"rel_tol": 0.0}, "rel_tol"),
    ({"valid": np.ones(3, bool)}, "valid"),
])
def test_bad_input_names_the_parameter(kwargs, field):
    with pytest.raises(InputError, match=field):
        detect_steady(np.ones(100), **kwargs)
