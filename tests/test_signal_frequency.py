"""Frequency estimation for records without frequency metadata."""

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.signal.frequency import estimate_frequency

FS = 50_000.0


@pytest.mark.parametrize("freq", [37.3, 400.0, 401.37, 1234.5])
def test_clean_sine_of_a_few_hundred_cycles_within_1e_6(freq):
    t = np.arange(int(300 * FS / freq)) / FS
    est = estimate_frequency(np.sin(2 * np.pi * freq * t + 0.4), FS)
    assert abs(est / freq - 1) < 1e-6


def test_harmonics_noise_and_offset_within_1e_4():
    rng = np.random.default_rng(0)
    freq = 397.77
    t = np.arange(int(200 * FS / freq)) / FS
    x = (2e-6 * np.sin(2 * np.pi * freq * t) + 6e-7 * np.sin(2 * np.pi * 3 * freq * t + 1)
         + 1e-3 + 2e-7 * rng.standard_normal(t.size))
    assert abs(estimate_frequency(x, FS) / freq - 1) < 1e-4


def test_search_band_limits():
    t = np.arange(100_000) / FS
    x = np.sin(2 * np.pi * 400 * t) + 0.5 * np.sin(2 * np.pi * 1300 * t)
    assert estimate_frequency(x, FS, min_hz=1000.0) == pytest.approx(1300.0, rel=1e-6)


@pytest.mark.parametrize("args, field", [
    ((np.zeros(1000), FS), "x"),
    ((np.ones(10), FS), "x"),
    ((np.sin(np.arange(1000.0)), 0.0), "fs"),
    ((np.array([0.0, np.inf] * 100), FS), "x"),
])
def test_bad_input_names_the_parameter(args, field):
    with pytest.raises(InputError, match=f"'{field}'"):
        estimate_frequency(*args)
