"""Zero-phase Butterworth low-pass (seed 002): response, streaming, bad input."""

import numpy as np
import pytest

from labjoint.errors import InputError
from scipy import signal as sps

from labjoint.signal.filter import (ZeroPhaseStream, analysis_cutoff, butter_sos, filtfilt_rows,
                                    lowpass, settling_samples)

FS = 50_000.0


def _tone(freq, n=50_000, fs=FS):
    return np.sin(2 * np.pi * freq * np.arange(n) / fs)


def _gain(freq, cutoff=3000.0, order=5):
    x = _tone(freq)
    y = lowpass(x, FS, cutoff, order)
    mid = slice(5000, -5000)
    return np.sqrt(np.mean(y[mid] ** 2) / np.mean(x[mid] ** 2))


def test_zero_phase_filter_is_minus_6_db_at_the_cutoff():
    # One Butterworth pass is -3 dB at fc; forward-backward squares it: |H|^2 = 1/2.
    assert 20 * np.log10(_gain(3000.0)) == pytest.approx(-6.0206, abs=0.02)


def test_squared_butterworth_magnitude_off_cutoff():
    for f in (1500.0, 4500.0, 6000.0):
        expected = 1.0 / (1.0 + (np.tan(np.pi * f / FS) / np.tan(np.pi * 3000.0 / FS)) ** 10)
        assert _gain(f) == pytest.approx(expected, rel=2e-3)


def test_fundamental_passes_unchanged_and_without_phase_shift():
    x = _tone(400.0)
    y = lowpass(x, FS)
    assert np.max(np.abs(y[2000:-2000] - x[2000:-2000])) < 1e-6


def test_stream_equals_whole_record_filtering():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.standard_normal((2, 300_000)), axis=1) + rng.standard_normal((2, 300_000))
    whole = lowpass(x, FS)
    stream = ZeroPhaseStream(FS, 3000.0, min_chunk=20_000)
    parts, i = [], 0
    while i < x.shape[1]:
        n = int(rng.integers(1, 40_000))
        parts.append(stream.push(x[:, i:i + n]))
        i += n
    parts.append(stream.finish())
    got = np.concatenate(parts, axis=1)
    assert got.shape == whole.shape
    scale = np.max(np.abs(whole), axis=1, keepdims=True)
    assert np.max(np.abs(got - whole) / scale) < 1e-9


@pytest.mark.parametrize("fs", [1.25e6, 2e6, 10e6])
def test_settling_length_is_bounded_at_high_sample_rates(fs):
    # The slowest Butterworth pole decays like exp(-sin(pi/10) 2 pi fc n / fs); 1e-12
    # needs ln(1e12)/(0.309 * 2 pi fc / fs) samples, times a little for the residues.
    # (The old doubling search never converged here: float64 round-off of the step
    # response sits above 1e-12 at these rates, so it grew until memory ran out.)
    sos = butter_sos(fs, 3000.0)
    n = settling_samples(sos)
    decay = np.log(1e12) / (np.sin(np.pi / 10) * 2 * np.pi * 3000.0 / fs)
    assert decay < n < 1.3 * decay + 100


@pytest.mark.parametrize("fs,cutoff,order", [(50e3, 3000.0, 5), (500e3, 3000.0, 5),
                                             (10e3, 4500.0, 5), (50e3, 3000.0, 1),
                                             (50e3, 20e3, 8)])
def test_settling_bound_holds_on_the_step_response(fs, cutoff, order):
    sos = butter_sos(fs, cutoff, order)
    n = settling_samples(sos, rtol=1e-9)
    step = sps.sosfilt(sos, np.ones(4 * n))
    assert np.max(np.abs(step[n:] - 1.0)) < 1e-9
    assert np.max(np.abs(step[: n // 4] - 1.0)) > 1e-9          # not a wild over-estimate


def test_stream_equals_whole_record_at_two_megasamples():
    fs = 2e6
    rng = np.random.default_rng(5)
    t = np.arange(400_000) / fs
    x = np.stack([np.sin(2 * np.pi * 400 * t), np.cos(2 * np.pi * 400 * t)])
    x += 0.01 * rng.standard_normal(x.shape)
    whole = lowpass(x, fs)
    stream = ZeroPhaseStream(fs, 3000.0, min_chunk=30_000)
    got = np.concatenate([stream.push(x[:, i:i + 25_000]) for i in range(0, x.shape[1], 25_000)]
                         + [stream.finish()], axis=1)
    assert got.shape == whole.shape
    assert np.max(np.abs(got - whole)) < 1e-9


def test_cutoff_at_or_above_nyquist_is_an_error_naming_cutoff():
    with pytest.raises(InputError, match="cutoff_hz"):
        lowpass(_tone(400.0, 1000, 5000.0), 5000.0, cutoff_hz=2500.0)
    with pytest.raises(InputError, match="cutoff_hz"):
        butter_sos(5000.0, cutoff_hz=-1.0)


def test_analysis_cutoff_lowers_to_045_fs_and_says_so():
    cutoff, rule = analysis_cutoff(5000.0, 3000.0)
    assert cutoff == pytest.approx(2250.0)
    assert "0.45" in rule and "3000" in rule
    assert analysis_cutoff(50_000.0, 3000.0)[0] == 3000.0


@pytest.mark.parametrize("kwargs, field", [
    ({"fs": 0.0}, "fs"), ({"fs": -5.0}, "fs"), ({"fs": float("nan")}, "fs"),
    ({"order": 0}, "order"), ({"order": 2.5}, "order"),
])
def test_bad_parameters_name_the_parameter(kwargs, field):
    args = {"x": _tone(400.0, 1000), "fs": FS, **kwargs}
    with pytest.raises(InputError, match=field):
        lowpass(**args)


def test_non_finite_samples_and_short_records_are_rejected():
    x = _tone(400.0, 1000)
    x[17] = np.nan
    with pytest.raises(InputError, match="'x'.*sample 17"):
        lowpass(x, FS)
    with pytest.raises(InputError, match="'x'"):
        lowpass(np.ones(10), FS)


@pytest.mark.parametrize("rows, n, fs, order", [(1, 5_000, 50_000.0, 5), (3, 20_000, 50_000.0, 5),
                                                (4, 60, 10_000.0, 2), (2, 30_000, 2e6, 7)])
def test_compiled_filtfilt_is_scipys_bit_for_bit(rows, n, fs, order):
    sos = butter_sos(fs, 3000.0 if fs > 7000 else 1000.0, order)
    x = np.random.default_rng(rows).standard_normal((rows, n)).cumsum(axis=1)
    assert np.array_equal(filtfilt_rows(sos, x), sps.sosfiltfilt(sos, x, axis=-1))
