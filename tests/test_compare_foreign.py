"""The comparison loop on records made by another generator (tests/jointgen.py: own laws,
own integration, CSV import format): hidden effects found, adequate models left alone,
effects outside the vocabulary not dressed up, bad input refused by name."""

import numpy as np
import pytest

from jointgen import law, random_run, sine_run, write_csv
from labjoint.compare import diagnose_runs, fit_runs, ladder_runs, prepare
from labjoint.compare.significance import noise_test
from labjoint.errors import InputError
from labjoint.signal.steady import detect_steady

FS, FREQ = 5000.0, 20.0
AMPS = (3e-6, 4.5e-6, 6e-6, 8e-6, 1e-5)
JENKINS = {"k": 2e6, "jenkins": (5e6, 10.0)}


def sines(tmp_path, hidden, noise, amps=AMPS, fs=FS, freq=FREQ, dc=0.0, tag="s"):
    """Steady-sine runs ramped up from rest over two cycles (12 cycles in all)."""
    out = []
    for i, a in enumerate(amps):
        t, u, F = sine_run(a, freq, fs, hidden, noise, dc=dc, seed=i)
        out.append(str(write_csv(tmp_path / f"{tag}{i}.csv", t, u, F, sample_rate_hz=fs,
                                 frequency_hz=freq)))
    return out


def one_record(tmp_path, hidden, noise, fs=FS, sweep=False, band=(10.0, 100.0), seconds=2.0,
               dc=0.0, name="rec"):
    t, u, F = random_run(5e-6, band, fs, seconds, hidden, noise, dc=dc, sweep=sweep)
    return str(write_csv(tmp_path / f"{name}.csv", t, u, F, sample_rate_hz=fs))


@pytest.mark.parametrize("noise", [0.002, 0.01, 0.05])
def test_exact_model_on_short_ramped_sines_is_adequate(tmp_path, noise):
    # 12 cycles with a 2-cycle ramp from rest: the ramp's last cycle is not steady
    r = diagnose_runs(sines(tmp_path, {"k": 2e6}, noise, dc=3e-5), "linear_stiffness",
                      candidates="viscous,coulomb,cubic_stiffness")
    assert r["adequate"], r["verdict"]
    assert not any(c["significant"] for c in r["candidates"])
    assert r["nrmse"] <= 1.5 * r["noise_floor"]
    assert r["parameters"]["linear_stiffness.k"]["value"] == pytest.approx(2e6, rel=0.01)


def test_short_ramp_is_not_steady():
    amp = np.array([0.75, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    amp = amp + 1e-4 * np.random.default_rng(0).standard_normal(amp.size)
    s = detect_steady(amp)
    assert s.start == 1 and s.n_steady == 9


def test_hidden_jenkins_in_sines_found_and_ladder_reaches_the_floor(tmp_path):
    files = sines(tmp_path, JENKINS, 0.01)
    d = diagnose_runs(files, "linear_stiffness", candidates="viscous,coulomb,cubic_stiffness")
    assert not d["adequate"]
    assert d["candidates"][0]["effect"] == "coulomb" and d["candidates"][0]["significant"]
    lad = ladder_runs(files, "linear_stiffness", candidates="viscous,coulomb,cubic_stiffness",
                      save=False, max_steps=2)
    assert lad["steps"][1]["added"] == "coulomb"
    assert lad["adequate"]
    last = lad["steps"][-1]
    assert last["nrmse"] <= 1.5 * lad["noise_floor"]
    f = fit_runs(files, "linear_stiffness+coulomb")
    p = {k: v["value"] for k, v in f["parameters"].items()}
    assert p["coulomb.f_s"] == pytest.approx(10.0, rel=0.03)
    assert p["coulomb.k"] == pytest.approx(5e6, rel=0.05)
    assert p["linear_stiffness.k"] == pytest.approx(2e6, rel=0.02)


def test_hidden_cubic_other_rate_and_offset(tmp_path):
    files = sines(tmp_path, {"k": 2e6, "k3": 5e16}, 0.01, fs=2000.0, freq=35.0, dc=-4e-5)
    d = diagnose_runs(files, "linear_stiffness", candidates="viscous,coulomb,cubic_stiffness")
    best = d["candidates"][0]
    assert best["effect"] == "cubic_stiffness" and best["significant"]
    assert best["nrmse_after_validation"] <= 1.5 * d["noise_floor_validation"]
    assert best["parameters"]["cubic_stiffness.k3"]["value"] == pytest.approx(5e16, rel=0.05)


@pytest.mark.parametrize("sweep", [False, True])
def test_record_from_rest_hidden_viscous_found(tmp_path, sweep):
    # 2 s of random (or swept) motion after 0.5 s at rest: judged from the start of motion
    f = one_record(tmp_path, {"k": 2e6, "c": 2000.0}, 0.01, sweep=sweep, dc=2e-5)
    d = diagnose_runs([f], "linear_stiffness", candidates="viscous,cubic_stiffness")
    assert d["kind"] == "record"
    best = d["candidates"][0]
    assert best["effect"] == "viscous" and best["significant"], d["verdict"]
    assert d["verdict"].startswith("add viscous")
    assert best["nrmse_after_validation"] <= 1.5 * d["noise_floor_validation"]
    assert best["parameters"]["viscous.c"]["value"] == pytest.approx(2000.0, rel=0.05)


def test_ladder_on_random_records_adds_slip_then_the_sensor_offset(tmp_path):
    # three records (validation: the middle rms), Jenkins joint, a 3 N force-sensor offset
    files = []
    for i, rms in enumerate((3e-6, 5e-6, 8e-6)):
        t, u, F = random_run(rms, (5.0, 60.0), FS, 3.0, JENKINS, 0.02, seed=i)
        files.append(str(write_csv(tmp_path / f"r{i}.csv", t, u, F + 3.0, sample_rate_hz=FS)))
    lad = ladder_runs(files, "linear_stiffness", candidates="viscous,coulomb,offset",
                      save=False, max_steps=3)
    assert [s["added"] for s in lad["steps"][1:]] == ["coulomb", "offset"]
    assert lad["adequate"]
    v = [s["nrmse_validation"] for s in lad["steps"]]
    assert v[0] > v[1] > v[2]
    assert lad["steps"][-1]["nrmse"] <= 1.5 * lad["noise_floor"]
    assert lad["steps"][-1]["parameters"]["offset.F0"]["value"] == pytest.approx(3.0, rel=0.05)


@pytest.mark.parametrize("noise, fs", [(0.01, 5000.0), (0.05, 2000.0)])
def test_record_exact_model_adequate(tmp_path, noise, fs):
    f = one_record(tmp_path, {"k": 2e6, "c": 2000.0}, noise, fs=fs)
    d = diagnose_runs([f], "linear_stiffness+viscous", candidates="coulomb,cubic_stiffness")
    assert d["adequate"], d["verdict"]
    assert not any(c["significant"] for c in d["candidates"])


def test_effect_outside_the_vocabulary_is_not_called_adequate(tmp_path):
    # quadratic drag c2 v|v|: viscous is the nearest law; whatever is proposed must help
    f = one_record(tmp_path, {"k": 2e6, "quad": 3e6}, 0.01)
    d = diagnose_runs([f], "linear_stiffness", candidates="coulomb,cubic_stiffness,viscous")
    assert not d["adequate"] and not d["verdict"].startswith("adequate")
    best = d["candidates"][0]
    assert best["effect"] == "viscous"            # the nearest law, and it truly helps
    assert best["nrmse_after_validation"] < 0.5 * d["nrmse_validation"]
    for c in d["candidates"]:
        if c["significant"]:
            assert c["nrmse_after_validation"] < d["nrmse_validation"]
    lad = ladder_runs([f], "linear_stiffness", candidates="coulomb,cubic_stiffness,viscous",
                      save=False, max_steps=2)
    assert not lad["adequate"]


def test_downward_sweep_blocks_span_its_lowest_frequency(tmp_path):
    f = one_record(tmp_path, {"k": 2e6}, 0.01, sweep=True, band=(90.0, 12.0), seconds=3.0)
    m = prepare([f], kind="record")[0]
    lowest = min(m.excitation.band_hz)
    assert lowest < 40.0 < max(m.excitation.band_hz)
    assert np.min(np.diff(m.spans, axis=1)) >= 4 * FS / lowest - 1


def test_noise_test_decides_only_with_few_units():
    rng = np.random.default_rng(1)
    base = 100.0 + rng.random(3)
    cand = base - np.array([90.0, 95.0, 20.0])    # large, uneven gain: t-test p > 0.01
    assert noise_test(base, cand, dforce_sq=50.0, noise_var=1e-3).p < 1e-6
    assert noise_test(base, cand, dforce_sq=50.0, noise_var=1e-3).method == "noise"
    same = base - 1e-3 * rng.standard_normal(3)    # changes within the noise: not decided
    assert noise_test(base, same, dforce_sq=50.0, noise_var=1e-3).p > 0.01
    many = np.tile(base, 4)
    assert noise_test(many, many - 1.0, 50.0, 1e-3).method == "paired t"


def test_bad_input_is_refused_by_name(tmp_path):
    files = sines(tmp_path, {"k": 2e6}, 0.01, amps=AMPS[:3])
    with pytest.raises(InputError, match="unknown effect 'frobnicate'"):
        diagnose_runs(files, "linear_stiffness+frobnicate")
    with pytest.raises(InputError, match="more than once"):
        fit_runs(files, "linear_stiffness+viscous+linear_stiffness")
    sweep = one_record(tmp_path, {"k": 2e6}, 0.01, sweep=True)
    with pytest.raises(InputError, match="kind='record'") as e:
        diagnose_runs([*files, sweep], "linear_stiffness", kind="sine")
    assert e.value.field == "kind"
    short = one_record(tmp_path, {"k": 2e6}, 0.01, seconds=0.3, name="short")
    with pytest.raises(InputError, match="too little of the record"):
        diagnose_runs([short], "linear_stiffness")
    t, u, F = sine_run(5e-6, FREQ, FS, {"k": 2e6}, 0.01)
    F[700] = np.nan
    bad = write_csv(tmp_path / "nan.csv", t, u, F, sample_rate_hz=FS)
    with pytest.raises(InputError, match="force_N"):
        diagnose_runs([*files, str(bad)], "linear_stiffness")


def test_generator_law_is_the_textbook_jenkins():
    u = np.concatenate([np.linspace(0, 1e-5, 50), np.linspace(1e-5, -1e-5, 100)])
    F = law(u, np.zeros_like(u), {"jenkins": (5e6, 10.0)})
    assert F.max() == pytest.approx(10.0) and F.min() == pytest.approx(-10.0)
    assert F[1] == pytest.approx(5e6 * u[1])


@pytest.mark.parametrize("hidden", [JENKINS, {"k": 2e6, "k3": 5e16}])
def test_noise_floor_at_few_samples_per_cycle(tmp_path, hidden):
    # 22.2 samples per cycle: resampled cycles read their interpolation error as noise
    t, u, F0 = sine_run(6e-6, 45.0, 1000.0, hidden, 0.0)
    _, _, F = sine_run(6e-6, 45.0, 1000.0, hidden, 0.01)
    m = prepare([str(write_csv(tmp_path / "f.csv", t, u, F, sample_rate_hz=1000.0,
                               frequency_hz=45.0))])[0]
    st = m.data.steady
    true = np.sqrt(np.mean(((F - F0)[m.offset:][st]) ** 2) / np.mean(m.data.force[st] ** 2))
    assert m.noise().nrmse == pytest.approx(true, rel=0.2)


def test_small_missing_damping_not_hidden_by_an_inflated_floor(tmp_path):
    files = sines(tmp_path, {**JENKINS, "c": 200.0}, 0.01, fs=1000.0, freq=45.0)
    d = diagnose_runs(files, "linear_stiffness+coulomb", candidates="viscous,cubic_stiffness")
    assert not d["adequate"], d["verdict"]
    assert d["candidates"][0]["effect"] == "viscous" and d["candidates"][0]["significant"]
