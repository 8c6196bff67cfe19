"""`labjoint backbone`: an FRF set of single modes written here (one per force level) and
model backbones, as JSON (design.md), and its refusals."""

import json

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.identify.backbone import frfset_backbone
from labjoint.signal.frfset import FrfSet

M = 2.0
LEVELS = {0.5: (30.0, 0.004), 2.0: (29.7, 0.007), 8.0: (29.1, 0.013)}     # level: (f_r, zeta)


def frfset(noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    f, lv, resp = [], [], []
    for level, (fr, z) in LEVELS.items():
        ff = np.linspace(fr * 0.97, fr * 1.03, 41)
        w, wr = 2 * np.pi * ff, 2 * np.pi * fr
        X = level / (M * (wr ** 2 - w ** 2 + 2j * z * wr * w))
        A = -w ** 2 * X
        A = A * (1 + noise * (rng.standard_normal(A.size) + 1j * rng.standard_normal(A.size)) / np.sqrt(2))
        f.append(ff)
        lv.append(np.full(ff.size, level))
        resp.append(A)
    f, lv, A = np.concatenate(f), np.concatenate(lv), np.concatenate(resp)
    std = np.maximum(noise, 1e-6) * np.abs(A)
    return FrfSet(f, lv, ["up"] * f.size, lv.astype(complex), ("tip",), A[:, None, None], std[:, None, None])


def test_step_sine_sets_give_each_levels_mode_and_its_amplitude_at_resonance():
    b = frfset_backbone(frfset(), method="fit")
    assert [p.extra["level_n"] for p in b.points] == list(LEVELS)
    for p, (level, (fr, z)) in zip(b.points, LEVELS.items()):
        assert p.frequency_hz == pytest.approx(fr, rel=1e-9)
        assert p.damping_ratio == pytest.approx(z, rel=1e-7)
        assert p.amplitude == pytest.approx(level / (M * 2 * z * (2 * np.pi * fr) ** 2), rel=1e-7)
    # phase quadrature between the steps (0.06-0.18 Hz apart, bandwidths 0.24-0.75 Hz): the
    # modal mass from the lowest sweep's phase slope, amplitudes interpolated between steps
    q = frfset_backbone(frfset())
    assert q.points[0].extra["modal_mass_kg"] == pytest.approx(M, rel=0.01)
    for p, (level, (fr, z)) in zip(q.points, LEVELS.items()):
        assert p.frequency_hz == pytest.approx(fr, rel=1e-5)
        assert p.damping_ratio == pytest.approx(z, rel=0.01)
        assert p.amplitude == pytest.approx(level / (M * 2 * z * (2 * np.pi * fr) ** 2), rel=0.01)
    noisy = frfset_backbone(frfset(noise=0.01, seed=4), method="fit")
    for p, (fr, z) in zip(noisy.points, LEVELS.values()):
        assert abs(p.frequency_hz - fr) < 4 * p.frequency_sd_hz and p.frequency_sd_hz < 1e-3 * fr
        assert abs(p.damping_ratio - z) < 4 * p.damping_sd and p.damping_sd < 0.1 * z


def test_cli_json_points_and_model(tmp_path, capsys):
    path = frfset().save(tmp_path / "set.json")
    assert main(["backbone", str(path), "--model", "coulomb", "--param", "coulomb.k=1e5",
                 "--param", "coulomb.f_s=1", "--mass", "1", "--stiffness", "3e4",
                 "--amplitudes", "1e-6:1e-3:5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [p["method"] for p in out["points"]] == ["step_sine"] * 3
    for p in out["points"] + out["model"]:
        assert set(p) >= {"amplitude", "amplitude_units", "frequency_hz", "damping_ratio", "method",
                          "amplitude_sd", "frequency_sd_hz", "damping_sd"}
        assert p["amplitude_units"] == "m"
    assert [p["amplitude"] for p in out["model"]] == pytest.approx(np.geomspace(1e-6, 1e-3, 5))
    assert out["model"][0]["frequency_hz"] == pytest.approx(np.sqrt(1.3e5) / (2 * np.pi))
    assert out["model"][0]["method"] == "sdof_harmonic"


@pytest.mark.parametrize("argv, field", [
    (["--model", "coulomb", "--param", "coulomb.k=1e5", "--param", "coulomb.f_s=1", "--amplitudes",
      "1e-6:1e-3:5"], "--mass"),
    (["--model", "coulomb", "--param", "coulomb.k", "--mass", "1"], "--param"),
    (["--model", "coulomb", "--param", "coulomb.k=1e5", "--mass", "1"], "--model.params"),
    ([], "inputs"),
])
def test_cli_refusals_are_one_line_exit_2(argv, field, capsys):
    assert main(["backbone", *argv, "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and len(cap.err.strip().splitlines()) == 1 and field in cap.err
