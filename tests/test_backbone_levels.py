"""Backbones from per-level broadband FRF sets (method frf_levels): one single-DOF mode
per level written here (its frequency and damping change with the level, as a joint's
equivalent linear mode does), against the closed forms: the mode's values, and the
amplitude of a narrow-band random response, x_rms^2 = S_FF / (8 zeta m^2 w_r^3)
(the integral of |H_d|^2 over frequency in Hz, S_FF the drive's one-sided PSD)."""

import json

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.identify.backbone import measured_backbones
from labjoint.identify.backbone_levels import frf_levels_backbone
from labjoint.signal.frfset import FrfSet

M = 2.0
LEVELS = {0.2: (30.0, 0.004), 1.0: (29.7, 0.007), 5.0: (29.1, 0.013)}     # drive rms N: (f_r, zeta)
DF, LO, HI = 0.05, 12.0, 70.0
SECOND = (95.0, 0.01, 0.5)       # a second mode above the band's middle: (f, zeta, residue ratio)


def broadband_set(noise=0.0, seed=0, second=False):
    rng = np.random.default_rng(seed)
    f1 = np.arange(LO, HI if not second else 140.0, DF)
    f, lv, resp, std, runs, meta = [], [], [], [], [], []
    for i, (level, (fr, z)) in enumerate(LEVELS.items()):
        w, wr = 2 * np.pi * f1, 2 * np.pi * fr
        X = 1.0 / (M * (wr ** 2 - w ** 2 + 2j * z * wr * w))
        if second:
            w2 = 2 * np.pi * SECOND[0]
            X = X + SECOND[2] / (M * (w2 ** 2 - w ** 2 + 2j * SECOND[1] * w2 * w))
        A = -w ** 2 * X * (1 + noise * (rng.standard_normal(w.size) + 1j * rng.standard_normal(w.size))
                           / np.sqrt(2))
        f.append(f1)
        lv.append(np.full(f1.size, level))
        resp.append(A)
        std.append(np.maximum(noise, 1e-9) * np.abs(A))
        runs += [f"bb{i}"] * f1.size
        meta.append({"run": f"bb{i}", "drive_rms": level, "kind": "broadband"})
    f, lv, A, sd = map(np.concatenate, (f, lv, resp, std))
    return FrfSet(f, lv, ["up"] * f.size, np.ones(f.size, complex), ("tip",), A[:, None, None],
                  sd[:, None, None], runs=tuple(runs), metadata={"levels": meta}, estimator="H1")


def closed_form_amplitude(level, fr, z, band=HI - LO):
    wr = 2 * np.pi * fr
    S_FF = level ** 2 / band                         # the drive rms spread evenly over the band
    return np.sqrt(2 * S_FF / (8 * z * M ** 2 * wr ** 3))


def test_each_levels_mode_and_its_amplitude_at_resonance():
    b = frf_levels_backbone(broadband_set())
    assert [p.method for p in b.points] == ["frf_levels"] * 3 and b.sensor == "tip"
    for p, (level, (fr, z)) in zip(b.points, LEVELS.items()):
        assert p.extra["level"] == level
        assert p.frequency_hz == pytest.approx(fr, rel=1e-6)
        assert p.damping_ratio == pytest.approx(z, rel=1e-3)
        # the band's ends hold a fraction ~ zeta of the power outside: 1 % is ample
        assert p.amplitude == pytest.approx(closed_form_amplitude(level, fr, z), rel=0.01)
        assert p.frequency_sd_hz >= 0 and p.damping_sd >= 0


def test_noise_gives_uncertainties_that_cover_the_truth_and_a_second_mode_is_left_out():
    b = frf_levels_backbone(broadband_set(noise=0.01, seed=3, second=True))
    for p, (level, (fr, z)) in zip(b.points, LEVELS.items()):
        assert abs(p.frequency_hz - fr) < max(4 * p.frequency_sd_hz, 2e-4 * fr)
        assert abs(p.damping_ratio - z) < max(4 * p.damping_sd, 0.05 * z)
        assert 0 < p.amplitude_sd < 0.05 * p.amplitude
        # the drive spread over 12-140 Hz; the mode's lines end halfway to the second mode
        assert p.amplitude == pytest.approx(closed_form_amplitude(level, fr, z, 140.0 - LO), rel=0.03)
    with pytest.raises(InputError, match="mode 3 asked"):
        frf_levels_backbone(broadband_set(second=True), mode=3)


def test_measured_backbones_and_the_cli_take_a_broadband_set_as_frf_levels(tmp_path, capsys):
    path = broadband_set().save(tmp_path / "bb.json")
    (b,) = measured_backbones([path])
    assert {p.method for p in b.points} == {"frf_levels"}
    assert main(["backbone", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [p["method"] for p in out["points"]] == ["frf_levels"] * 3
    assert [p["frequency_hz"] for p in out["points"]] == pytest.approx([v[0] for v in LEVELS.values()], rel=1e-6)
