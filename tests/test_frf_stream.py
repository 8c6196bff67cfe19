"""A record too long to load goes through the Welch sums block by block: the same FRF as
the record read whole."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import signal as sps

from labjoint.identify import records
from labjoint.cli.main import main
from labjoint.signal import broadband, broadband_stream
from tests.test_distortion_cli import _run_file


def test_streamed_welch_equals_the_whole_record():
    fs, n = 512.0, 1 << 18
    rng = np.random.default_rng(1)
    f = rng.normal(size=n) + 0.2
    b, a = sps.butter(2, [0.05, 0.2], "band")
    y = np.vstack([sps.lfilter(b, a, f) + 1e-2 * rng.normal(size=n) + 3.0, 0.5 * f])
    whole = broadband.estimate(f, y, fs)
    old = broadband_stream.BLOCK
    broadband_stream.BLOCK = 5000            # blocks that cut segments anywhere
    try:
        part = broadband_stream.estimate_streamed(lambda p, q: (f[p:q], y[:, p:q]), lambda p, q: f[p:q],
                                                  n, fs, 2, dtype=np.float64)
    finally:
        broadband_stream.BLOCK = old
    assert np.allclose(part.h, whole.h, rtol=1e-9) and np.allclose(part.coherence, whole.coherence)
    assert abs(part.drive_rms / whole.drive_rms - 1) < 1e-3   # over whole 0.05 s windows


def test_a_streamed_burst_record_takes_the_burst_estimator_asked_for():
    """A burst record is read whole by the streamed path and answered as by the estimator
    in memory, by the default ("block") and by burst="driven"; a bad name refused."""
    fs = 256.0
    rng = np.random.default_rng(4)
    f = np.concatenate([rng.normal(size=1 << 13), np.zeros(1 << 13)])
    b, a = sps.butter(2, [0.05, 0.2], "band")
    y = np.vstack([sps.lfilter(b, a, f) + 1e-3 * rng.normal(size=f.size)])
    for mode, text in (("block", "1 burst block(s)"), ("driven", "driven part of 1 burst(s)")):
        whole = broadband.estimate(f, y, fs, burst=mode)
        part = broadband_stream.estimate_streamed(lambda p, q: (f[p:q], y[:, p:q]), lambda p, q: f[p:q],
                                                  f.size, fs, 1, burst=mode, dtype=np.float64)
        assert text in part.method and part.method == whole.method
        assert np.array_equal(part.h, whole.h)
    with pytest.raises(broadband.InputError, match="'burst'"):
        broadband_stream.estimate_streamed(lambda p, q: (f[p:q], y[:, p:q]), lambda p, q: f[p:q],
                                           f.size, fs, 1, burst="whole")


def test_cli_reads_a_long_record_in_blocks(tmp_path, capsys, monkeypatch):
    fs, n = 256.0, 1 << 16
    rng = np.random.default_rng(2)
    v = rng.normal(size=n)
    w, z = 2 * np.pi * 30.0, 0.02
    num, den, _ = sps.cont2discrete(([1.0, 0.0, 0.0], [1, 2 * z * w, w ** 2]), 1 / fs, "bilinear")
    acc = sps.lfilter(num.ravel(), den, v)
    p = _run_file(tmp_path / "long.h5", {"f": ("force", "N", v), "a": ("acceleration", "m/s^2", acc)}, fs)
    assert main(["frf", str(p), "--out", str(tmp_path / "whole.json"), "--json"]) == 0
    whole = json.loads(capsys.readouterr().out)["levels"][0]
    monkeypatch.setattr(records, "STREAM_VALUES", 1000)
    assert main(["frf", str(p), "--out", str(tmp_path / "part.json"), "--json"]) == 0
    part = json.loads(capsys.readouterr().out)["levels"][0]
    assert "read in blocks" in part["method"] and "read in blocks" not in whole["method"]
    a = json.loads((tmp_path / "whole.json").read_text())
    b = json.loads((tmp_path / "part.json").read_text())
    assert a["frequencies_hz"] == b["frequencies_hz"]
    ra, rb = np.array(a["response"]), np.array(b["response"])
    assert np.allclose(ra, rb, rtol=1e-4, atol=1e-6 * np.abs(ra).max())   # single precision
    assert main(["modes", str(p), "--band", "5:100", "--json"]) == 0
    lv = json.loads(capsys.readouterr().out)["levels"][0]
    fd = fs / np.pi * np.arctan(np.pi * 30.0 / fs)
    assert abs(lv["modes"][0]["frequency_hz"] / fd - 1) < 2e-3
