"""Distortion against closed forms (a known quadratic and cubic term), and the frf, modes
and distortion commands on run files with quantities and units (volts stay volts)."""

from __future__ import annotations

import json
import math

import h5py
import numpy as np
import pytest
from scipy import signal as sps

from labjoint.cli.main import main
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.signal.distortion import harmonics, multisine
from labjoint.storage import layout


def _run_file(path, channels: dict, fs: float, metadata: dict | None = None):
    """A run file holding ``channels`` {name: (quantity, unit, samples)} in SI units."""
    specs = [ChannelSpec(name=n, sensor="imported", quantity=q, unit=u, sensitivity=1.0,
                         range_v=math.inf, coupling="DC") for n, (q, u, _) in channels.items()]
    n = len(next(iter(channels.values()))[2])
    with h5py.File(path, "w", libver="latest") as f:
        layout.create_layout(f, name=path.stem, uid="u-" + path.stem, channels=specs,
                             sample_rate_hz=fs, metadata=dict(metadata or {}, plan="import"),
                             source="imported", signal=None, data_units=None)
        data = f["entry/data"]
        for key, v in [("time", np.arange(n) / fs)] + [(k, c[2]) for k, c in channels.items()]:
            data[key].resize((n,))
            data[key][:] = v
        f["entry"]["n_samples"][()] = n
        f["entry"]["status"][()] = np.bytes_(b"complete")
    return path


def test_harmonics_of_a_known_quadratic_and_cubic_term():
    fs, f0 = 1000.0, 7.3
    t = np.arange(80_000) / fs
    rng = np.random.default_rng(0)
    a = 0.8
    u = a * np.sin(2 * np.pi * f0 * t)
    q, c = 0.05, 0.02
    y = u + q * u ** 2 + c * u ** 3 + 1e-4 * rng.normal(size=t.size)
    _, res = harmonics({"u": u, "y": y}, fs, drive="u", orders=4)
    h1 = a + 0.75 * c * a ** 3           # sin^3 = (3 sin - sin 3)/4; sin^2 = (1 - cos 2)/2
    want = {2: q * a ** 2 / 2 / h1, 3: c * a ** 3 / 4 / h1, 4: 0.0}
    for h in res["y"][1:]:
        assert h["ratio"] == pytest.approx(want[h["order"]], abs=3 * h["stderr"] + 2e-5)
    assert res["u"][1]["ratio"] < 1e-6


def _odd_multisine(N, fs, rng, P=8):
    k = np.arange(1, 200, 2)                  # odd lines
    k = k[rng.random(k.size) > 0.3]           # random-odd: about a third left as detection lines
    U = np.zeros(N // 2 + 1, complex)
    U[k] = np.exp(2j * np.pi * rng.random(k.size))
    u1 = np.fft.irfft(U, N)
    u1 /= u1.std()
    return np.tile(u1, P + 1)


@pytest.mark.parametrize("law, kinds", [("quadratic", ["even"]), ("cubic", ["odd"]), ("linear", [])])
def test_multisine_detection_lines_tell_odd_from_even(law, kinds):
    fs, N = 1000.0, 2000
    rng = np.random.default_rng(4)
    u = _odd_multisine(N, fs, rng)
    b, a = sps.butter(2, 0.2)
    x = sps.lfilter(b, a, u)
    y = x + {"quadratic": 0.05 * x ** 2, "cubic": 0.05 * x ** 3, "linear": 0 * x}[law]
    y = y + 1e-3 * rng.normal(size=y.size)
    r = multisine(u, y, fs, N)
    s = r["summary"]
    if not kinds:
        assert s.startswith("no nonlinear distortion")
    else:
        assert s.startswith(f"nonlinear, {kinds[0]},"), s
    std, total = np.array(r["bla"]["std"]), np.array(r["bla"]["std_total"])
    assert np.all(total >= std)
    if law == "cubic":                        # the stochastic nonlinear part dominates the noise
        assert np.median(total / std) > 3
    # the BLA of the linear case is the filter's own FRF at the excited lines
    if law == "linear":
        f = np.array(r["bla"]["frequency_hz"])
        _, h = sps.freqz(b, a, worN=f, fs=fs)
        g = np.array(r["bla"]["re"]) + 1j * np.array(r["bla"]["im"])
        assert np.max(np.abs(g - h)) < 5 * max(r["bla"]["std"]) + 1e-3


def test_cli_frf_modes_distortion_on_run_files(tmp_path, capsys):
    fs = 256.0
    rng = np.random.default_rng(9)
    n = 1 << 16
    v = rng.normal(size=n) * 0.1
    w, z = 2 * np.pi * 20.0, 0.02
    sysd = sps.cont2discrete(([w ** 2 * 1e-3, 0], [1, 2 * z * w, w ** 2]), 1 / fs, "bilinear")
    vel = sps.lfilter(sysd[0].ravel(), sysd[1], v)   # an acceleration per volt (velocity numerator: a shape only), one mode at 20 Hz
    p = _run_file(tmp_path / "rand.h5", {"amp": ("voltage", "V", v), "laser": ("velocity", "m/s", vel)},
                  fs, {"level": 0.1})
    assert main(["frf", str(p), "--out", str(tmp_path / "f.json"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    lv = out["levels"][0]
    assert lv["units"] == "m/s/V" and lv["level_units"] == "V" and lv["level"] == 0.1
    assert main(["modes", str(tmp_path / "f.json"), "--band", "5:60", "--json"]) == 0
    modes = json.loads(capsys.readouterr().out)["levels"][0]["modes"]
    fn = w * np.sqrt(1 - z ** 2) / (2 * np.pi)   # bilinear maps the pole's frequency: prewarped below
    fd = fs / np.pi * np.arctan(np.pi * 20.0 / fs)
    assert modes[0]["frequency_hz"] == pytest.approx(fd, rel=2e-3), (fn, fd)
    t = np.arange(40_000) / fs
    u = 0.1 * np.sin(2 * np.pi * 5.0 * t)
    s = _run_file(tmp_path / "sine.h5", {"amp": ("voltage", "V", u),
                                         "laser": ("acceleration", "m/s^2", u + 0.3 * u ** 2 / 0.1)}, fs)
    assert main(["distortion", str(s), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)["runs"][0]
    h2 = r["channels"]["laser"]["harmonics"][0]
    assert r["channels"]["amp"]["units"] == "V" and h2["order"] == 2
    assert h2["ratio"] == pytest.approx(0.3 * 0.1 / 2 / 0.1 * 0.1 / 0.1, rel=1e-3)


def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    fs = 256.0
    x = np.random.default_rng(0).normal(size=4096)
    p = _run_file(tmp_path / "nodrive.h5", {"laser": ("acceleration", "m/s^2", x)}, fs)
    assert main(["frf", str(p), "--out", str(tmp_path / "f.json"), "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nodrive.h5" in err[0] and "drive" in err[0]
    assert not (tmp_path / "f.json").exists()
    q = _run_file(tmp_path / "short.h5", {"amp": ("voltage", "V", x[:200]), "laser": ("acceleration", "m/s^2", x[:200])}, fs)
    assert main(["frf", str(q), "--out", str(tmp_path / "f.json"), "--method", "welch",
                 "--nperseg", "256", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "short.h5" in err[0]
    assert main(["frf", str(q), "--out", str(tmp_path / "f.json"), "--burst", "lrm", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'burst'" in err[0] and "block, driven" in err[0] and "'lrm'" in err[0]
    assert not (tmp_path / "f.json").exists()
    r = _run_file(tmp_path / "ok.h5", {"amp": ("voltage", "V", x), "laser": ("acceleration", "m/s^2", x)}, fs)
    main(["frf", str(r), "--out", str(tmp_path / "g.json")])
    capsys.readouterr()
    assert main(["modes", str(tmp_path / "g.json"), "--band", "100:101", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "g.json" in err[0] and "band" in err[0]


def test_cli_distortion_of_a_multisine_and_modes_of_a_run(tmp_path, capsys):
    fs, N = 1000.0, 2000
    rng = np.random.default_rng(12)
    u = _odd_multisine(N, fs, rng, P=6)
    b, a = sps.butter(2, 0.2)
    x = sps.lfilter(b, a, u)
    p = _run_file(tmp_path / "ms.h5", {"amp": ("voltage", "V", 0.1 * u),
                                       "acc": ("acceleration", "m/s^2", x + 0.05 * x ** 3
                                               + 1e-3 * rng.normal(size=u.size))}, fs)
    assert main(["distortion", str(p), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)["runs"][0]
    assert r["excitation"] == "multisine" and r["period_s"] == pytest.approx(2.0)
    assert r["summary"].startswith("nonlinear, odd,"), r["summary"]
    assert r["channels"]["acc"]["units"] == "m/s^2" and r["channels"]["acc"]["harmonics"] == []
    # modes straight from a run file: one 20 Hz mode under random force
    v = rng.normal(size=1 << 15)
    w, z = 2 * np.pi * 20.0, 0.02
    sysd = sps.cont2discrete(([1.0, 0.0, 0.0], [1, 2 * z * w, w ** 2]), 1 / 256.0, "bilinear")
    q = _run_file(tmp_path / "r.h5", {"f": ("force", "N", v), "a": ("acceleration", "m/s^2",
                                       sps.lfilter(sysd[0].ravel(), sysd[1], v))}, 256.0)
    assert main(["modes", str(q), "--band", "5:60", "--json"]) == 0
    lv = json.loads(capsys.readouterr().out)["levels"][0]
    assert lv["units"] == "m/s^2/N" and lv["level_units"] == "N"
    fd = 256.0 / np.pi * np.arctan(np.pi * 20.0 / 256.0)   # the bilinear map's 20 Hz
    assert lv["modes"][0]["frequency_hz"] == pytest.approx(fd, rel=2e-3)


def test_two_records_at_one_level_stay_two_levels(tmp_path, capsys):
    fs = 256.0
    rng = np.random.default_rng(13)
    w, z = 2 * np.pi * 25.0, 0.02
    num, den, _ = sps.cont2discrete(([1.0, 0.0, 0.0], [1, 2 * z * w, w ** 2]), 1 / fs, "bilinear")
    paths = []
    for k in range(2):
        b, a = sps.butter(4, 60.0, fs=fs)                 # the drive's band: 0-60 Hz
        v = sps.lfilter(b, a, rng.normal(size=1 << 15))
        paths.append(str(_run_file(tmp_path / f"r{k}.h5", {"f": ("force", "N", v),
                                   "a": ("acceleration", "m/s^2", sps.lfilter(num.ravel(), den, v))},
                                   fs, {"level": 2.0})))
    assert main(["frf", *paths, "--out", str(tmp_path / "f.json"), "--json"]) == 0
    lv = json.loads(capsys.readouterr().out)["levels"]
    assert [x["level"] for x in lv] == [2.0, 2.0] and 60 < lv[0]["band_hz"][1] < 100   # 1 % power
    assert main(["frf", *paths, "--out", str(tmp_path / "g.json"), "--band", "all", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["levels"][0]["lines"] > lv[0]["lines"]
    assert main(["modes", str(tmp_path / "f.json"), "--json"]) == 0
    levels = json.loads(capsys.readouterr().out)["levels"]
    assert [x["run"] for x in levels] == ["r0", "r1"]
    fd = fs / np.pi * np.arctan(np.pi * 25.0 / fs)
    assert all(abs(x["modes"][0]["frequency_hz"] / fd - 1) < 2e-3 for x in levels)
