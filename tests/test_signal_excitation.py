"""Excitation detection: every kind told from the signal, lab artefacts tolerated."""

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.signal.excitation import detect_excitation, require_sine

FS = 20_000.0
T = np.arange(int(2 * FS)) / FS
RNG = np.random.default_rng(7)


def _multisine(fs=750.0, n=8192, periods=4, band=(5.0, 150.0), snr_db=None, seed=1):
    rng = np.random.default_rng(seed)
    k = np.arange(n // 2 + 1)
    f = k * fs / n
    sel = (f >= band[0]) & (f <= band[1])
    spec = np.zeros(n // 2 + 1, complex)
    spec[sel] = np.exp(2j * np.pi * rng.random(sel.sum()))
    period = np.fft.irfft(spec, n)
    x = np.tile(period / period.std(), periods)
    if snr_db is not None:
        x = x + 10 ** (-snr_db / 20) * rng.standard_normal(x.size)
    return x, int(sel.sum()), n / fs


def test_steady_sine_with_harmonics_noise_and_quantisation():
    x = np.sin(2 * np.pi * 400 * T) + 0.2 * np.sin(2 * np.pi * 1200 * T + 1)
    x = x + 0.3 * RNG.standard_normal(T.size)
    x = np.round(x / 1e-3) * 1e-3
    e = detect_excitation(x, FS)
    assert e.kind == "sine" and e.frequency_hz == pytest.approx(400.0, rel=1e-4)
    require_sine(e, "labjoint analyze")                    # accepted


def test_lab_record_rest_ramps_offset_and_hum_is_a_sine():
    env = np.clip(np.minimum((T - 0.3) / 0.2, (1.7 - T) / 0.2), 0, 1)
    env = 0.5 - 0.5 * np.cos(np.pi * env)                  # raised-cosine ramps, rest around
    x = 2.0 + env * np.sin(2 * np.pi * 150 * T) + 0.03 * np.sin(2 * np.pi * 50 * T)
    e = detect_excitation(x, FS)
    assert e.kind == "sine" and e.frequency_hz == pytest.approx(150.0, rel=1e-3)
    assert e.active_s[0] == pytest.approx(0.3, abs=0.1) and e.active_s[1] == pytest.approx(1.7, abs=0.1)


@pytest.mark.parametrize("snr_db", [None, 10.0])
def test_multisine_period_and_lines(snr_db):
    x, n_lines, period = _multisine(snr_db=snr_db)
    e = detect_excitation(x, 750.0)
    assert e.kind == "multisine"
    assert e.period_s == pytest.approx(period)
    assert abs(len(e.lines_hz) - n_lines) <= 0.02 * n_lines
    assert min(e.lines_hz) == pytest.approx(5.0, abs=0.2) and max(e.lines_hz) == pytest.approx(150.0, abs=0.2)
    with pytest.raises(InputError, match="multisine.*not a steady sine.*labjoint fit"):
        require_sine(e, "`labjoint analyze`")


@pytest.mark.parametrize("f0, f1", [(20.0, 500.0), (500.0, 50.0), (395.0, 405.0)])
def test_swept_sine_either_direction_even_when_slow(f0, f1):
    x = np.sin(2 * np.pi * (f0 * T + (f1 - f0) * T ** 2 / (2 * T[-1])))
    e = detect_excitation(x, FS)
    assert e.kind == "swept_sine"
    lo, hi = e.band_hz
    assert (hi - lo) * (f1 - f0) > 0                       # direction kept


def test_random_and_transient_and_silence():
    assert detect_excitation(RNG.standard_normal(T.size), FS).kind == "random"
    impact = np.where(T > 0.1, np.exp(-(T - 0.1) / 0.05) * np.sin(2 * np.pi * 300 * T), 0.0)
    assert detect_excitation(impact, FS).kind == "transient"
    assert detect_excitation(np.full(1000, 3.0), FS).kind == "none"


def test_sine_after_a_start_up_overshoot_is_a_sine_and_a_slow_decay_is_a_transient():
    # a run from rest: the structure rings at 3x the steady level for the first 10 %
    start = 1.0 + 4.0 * np.exp(-T / 0.04)
    e = detect_excitation(start * np.sin(2 * np.pi * 400 * T), FS)
    assert e.kind == "sine" and e.frequency_hz == pytest.approx(400.0, rel=1e-4)
    # a lightly damped free decay looks like a sine locally; its level never holds still
    decay = np.exp(-T / 0.5) * np.sin(2 * np.pi * 400 * T)
    assert detect_excitation(decay, FS).kind == "transient"


def test_two_incommensurate_tones_are_not_a_sine():
    e = detect_excitation(np.sin(2 * np.pi * 400 * T) + 0.8 * np.sin(2 * np.pi * 633.3 * T), FS)
    assert e.kind != "sine"


def test_too_short_is_an_error():
    with pytest.raises(InputError, match="signal"):
        detect_excitation(np.ones(5), FS)


@pytest.mark.parametrize("seed", range(12))
def test_a_broadband_record_is_never_read_as_a_sweep_by_chance(seed):
    """The dominant line of a multisine or of band-limited noise wanders between quarters
    by chance (monotonic in about 1 of 12 draws); that alone must not make a sweep."""
    fs, n = 750.0, 1024
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.where((f >= 5) & (f <= 150), np.exp(2j * np.pi * rng.random(f.size)), 0)
    period = np.fft.irfft(spec, n)
    ms = np.tile(period, 4)[rng.integers(0, n):][:3 * n + 100]     # starts anywhere in a period
    assert detect_excitation(ms, fs).kind == "multisine"
    noise = np.fft.irfft(np.where((np.fft.rfftfreq(4096, 1 / fs) >= 5), 1.0, 0.0)
                         * np.fft.rfft(rng.standard_normal(4096)), 4096)
    assert detect_excitation(noise, fs).kind == "random"
