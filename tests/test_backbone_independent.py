"""The loop on a backbone that labjoint did not compute: a single-DOF oscillator with a
Jenkins element (spring k_t in series with a Coulomb slider f_s) beside springs and a
dashpot, m u'' + c u' + (k + k_j) u + g_J(u) = 0, whose first-harmonic (Masing) backbone
is written here in closed form (Caughey's bilinear hysteresis): with a_s = f_s / k_t and
cos(beta) = 1 - 2 a_s / a for a > a_s,

    k_1(a) = k_t / pi (beta - sin(2 beta) / 2),   W(a) = 4 f_s (a - a_s)   (k_t, 0 below a_s)
    w(a)^2 = (k + k_j + k_1(a)) / m,               zeta(a) = (W + pi c w a^2) / (2 pi m w^2 a^2).

Stated noise is added; the comparison judges it in the single-DOF modal form
(:class:`labjoint.structure.sdof_backbone.SdofPredictor`, EPMC with one harmonic) from a
linear joint: diagnose must name a hysteretic slip law and the ladder reach the noise."""

import numpy as np
import pytest

from labjoint.compare.diagnosis import DiagnoseSettings
from labjoint.compare.kinds.backbone import prepare_backbones
from labjoint.compare.ladders import build_ladder
from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.signal.backbone import Backbone, BackbonePoint
from labjoint.structure.law import JointLaw
from labjoint.structure.sdof_backbone import SdofPredictor

M, K, C = 2.0, 7e4, 2.8                  # kg, N/m, N s/m: the mode without its joint
KJ, KT, FS = 1e4, 3e4, 3.0               # the joint: parallel spring, Jenkins spring and slider
F_SD, Z_SD = 2e-3, 0.02                  # Hz; relative
CANDIDATES = ("viscous", "coulomb", "iwan")


def jenkins_backbone(a):
    """Frequency (Hz) and damping ratio of the closed form (module docstring)."""
    a = np.asarray(a, float)
    a_s = FS / KT
    beta = np.arccos(np.clip(1 - 2 * a_s / a, -1.0, 1.0))
    k1 = np.where(a > a_s, KT / np.pi * (beta - 0.5 * np.sin(2 * beta)), KT)
    W = np.where(a > a_s, 4 * FS * (a - a_s), 0.0)
    w = np.sqrt((K + KJ + k1) / M)
    return w / (2 * np.pi), (W + np.pi * C * w * a * a) / (2 * np.pi * M * w * w * a * a)


def measured(n=14, seed=3) -> Backbone:
    rng = np.random.default_rng(seed)
    a = np.geomspace(3e-5, 3e-3, n)
    f, z = jenkins_backbone(a)
    pts = [BackbonePoint(ai, fi + F_SD * rng.standard_normal(), zi * (1 + Z_SD * rng.standard_normal()),
                         "phase_resonance", 0.0, F_SD, Z_SD * zi) for ai, fi, zi in zip(a, f, z)]
    return Backbone(pts, "m", "displacement", "x")


def predictor() -> SdofPredictor:
    return SdofPredictor(JointLaw("linear_stiffness", {"linear_stiffness.k": KJ}), M, stiffness_n_per_m=K,
                         damping_ns_per_m=C, harmonics=1, sensor="x")


@pytest.fixture(scope="module")
def ms():
    return prepare_backbones([("jenkins", measured())], predictor(), harmonics=1, samples=256)


def test_the_truth_sits_in_its_noise_and_the_linear_joint_far_outside(ms):
    truth = Model.parse("linear_stiffness+coulomb")
    vals = {"linear_stiffness.k": KJ, "coulomb.k": KT, "coulomb.f_s": FS}
    for m in ms:
        r = m.predict(truth, vals) - m.data.force
        assert 0.4 < np.sqrt(np.mean(r ** 2)) < 1.6            # whitened: unit variance
        lin = m.predict(Model.parse("linear_stiffness"), {"linear_stiffness.k": KJ}) - m.data.force
        assert np.sqrt(np.mean(lin ** 2)) > 100


def test_diagnose_names_the_slip_law_and_the_ladder_reaches_the_noise(ms):
    """The ladder's first step is the linear baseline's diagnosis (its verdict and what
    fails where); its second the slip law added."""
    settings = DiagnoseSettings(candidates=CANDIDATES)
    lad = build_ladder(ms, "linear_stiffness", settings=settings, max_steps=2).to_dict()
    first = lad["steps"][0]
    assert first["verdict"].startswith("add coulomb"), first["verdict"]
    assert any(t.startswith("damping too low above") for t in first["remaining"]), first["remaining"]
    assert any(t.startswith("frequency too high above") for t in first["remaining"]), first["remaining"]
    assert {c["effect"]: c["significant"] for c in first["candidates"]}["viscous"] is False
    assert [s.get("added") for s in lad["steps"][1:2]] == ["coulomb"]
    nrmse = [s["nrmse_validation"] for s in lad["steps"]]
    floor = lad["noise_floor_validation"]
    assert nrmse[0] > 50 * floor and nrmse[-1] < 1.5 * floor, (nrmse, floor)
    assert "remaining" not in lad["steps"][-1]                     # adequate: nothing remains
    p = lad["steps"][1]["parameters"]
    assert p["coulomb.f_s"]["value"] == pytest.approx(FS, rel=0.02)
    assert p["coulomb.k"]["value"] == pytest.approx(KT, rel=0.05)


def test_single_dof_predictor_refuses_bad_numbers():
    law = JointLaw("linear_stiffness", {"linear_stiffness.k": KJ})
    for kw, field in (({"mass_kg": 0.0}, "mass_kg"), ({"mass_kg": 1.0, "damping_ns_per_m": -1.0},
                                                      "damping_ns_per_m"),
                      ({"mass_kg": 1.0, "harmonics": 0}, "harmonics")):
        with pytest.raises(InputError) as e:
            SdofPredictor(law, **kw)
        assert e.value.field == field


def test_the_linear_damping_identified_from_the_linear_range_puts_a_wrong_file_right():
    """The model's dashpot 60 % too strong (a structure file's guess): the points below
    the slider's slip (a_s = 1e-4 m) give the mode's damping, c / (2 sqrt((k + k_j + k_t) m)),
    and the calibrated model meets the truth's backbone within its noise."""
    from labjoint.compare.backbone_damping import calibrate, linear_range

    b = measured(n=14)
    lr = linear_range([b])
    z0 = C / (2 * np.sqrt((K + KJ + KT) * M))
    assert lr["zeta"] == pytest.approx(z0, abs=3 * lr["zeta_sd"]) and lr["zeta_sd"] < 0.02 * z0
    assert lr["amplitude_max"] < FS / KT < lr["onset_amplitude"]
    wrong = SdofPredictor(JointLaw("linear_stiffness+coulomb", {"linear_stiffness.k": KJ, "coulomb.k": KT,
                                                                 "coulomb.f_s": FS}),
                          M, stiffness_n_per_m=K, damping_ns_per_m=1.6 * C, harmonics=1, sensor="x")
    fixed, note = calibrate(wrong, [b])
    assert fixed.linear_damping_ratio() == pytest.approx(lr["zeta"], rel=1e-12) and "scaled by" in note
    truth = Model.parse("linear_stiffness+coulomb")
    vals = {"linear_stiffness.k": KJ, "coulomb.k": KT, "coulomb.f_s": FS}
    rms = []
    for pr in (wrong, fixed):
        (m,) = prepare_backbones([("jenkins", b)], pr, harmonics=1, split=False, samples=256)
        r = m.predict(truth, vals) - m.data.force
        rms.append(float(np.sqrt(np.mean(r ** 2))))
    assert rms[0] > 5 and rms[1] < 1.6, rms
    # a backbone without a linear range (every point slipping) is refused, naming the option
    with pytest.raises(InputError, match="no linear range") as e:
        linear_range([Backbone([p for p in b.points if p.amplitude > 2 * FS / KT], "m", "displacement", "x")])
    assert e.value.field == "linear_damping"


def test_linear_damping_measured_without_a_backbone_is_refused_in_one_line(tmp_path, capsys):
    from frfdata import write_linear_structure
    from labjoint.cli.main import main
    from test_cli_backbone import frfset

    write_linear_structure(tmp_path / "s.toml")
    path = frfset().save(tmp_path / "set.json")
    code = main(["fit", str(path), "--structure", str(tmp_path / "s.toml"), "--model", "linear_stiffness",
                 "--linear-damping", "measured", "--json", "--quiet"])
    cap = capsys.readouterr()
    assert code == 2 and cap.out == "" and len(cap.err.strip().splitlines()) == 1
    assert "linear_damping" in cap.err and "backbone" in cap.err


def test_a_damping_that_rises_from_the_lowest_amplitudes_is_extrapolated_to_zero():
    """A joint that micro-slips from the lowest amplitudes (continuous Iwan, chi = 0: its
    damping and frequency drop ~ A) has no flat range: the mean of the low points would
    carry the joint's share (+0.6 to +1.2 % here, 3-5 sd); the range's weighted line gives
    the structure's zeta_0 at zero amplitude. A flat range (a stuck joint) keeps its mean.
    Ringdown-like points: 2e-6 to 1e-3 m, uncertainties growing towards the noise."""
    from labjoint.compare.backbone_damping import linear_range

    a = np.geomspace(2e-6, 1e-3, 36)
    zsd = np.clip(5e-6 * (1e-4 / a) ** 0.8, 4e-6, 5e-4)
    fsd = np.clip(2e-4 * (1e-4 / a) ** 0.8, 1e-4, 1e-2)
    z0 = 0.0042
    for seed in range(3):
        rng = np.random.default_rng(seed)
        for rise in (2.4, 0.0):
            z = z0 + rise * a + zsd * rng.standard_normal(a.size)
            f = 28.56 - 60 * rise * a + fsd * rng.standard_normal(a.size)
            pts = [BackbonePoint(float(x), float(fi), float(zi), "ringdown_peaks", 1e-9, float(fs), float(s))
                   for x, zi, fi, s, fs in zip(a, z, f, zsd, fsd)]
            lr = linear_range([Backbone(pts, "m", "displacement", "x")])
            assert lr["zeta"] == pytest.approx(z0, abs=3 * lr["zeta_sd"]), (seed, rise, lr)
            if rise:
                assert lr["extrapolated"] and lr["zeta_sd"] < 0.01 * z0
