"""Plans as exact message lists, load_plan errors, the H1 estimator: no hardware."""

import json
import math

import numpy as np
import pytest

from labjoint.acquisition.frf import frf_h1, stepped_frf
from labjoint.acquisition.messages import (Configure, Measure, Measurement, Output, Ramp, Record,
                                           SetTorque, SteadyResult, WaitSteady)
from labjoint.acquisition.plans import (PLANS, amplitude_sweep, broadband, dry_run, dwell,
                                        friction_test, load_plan, sensor_calibration, step_sine,
                                        torque_series)
from labjoint.errors import InputError

W = WaitSteady(max_cycles=50, tol=0.05, window=4)
STEADY = dict(steady_max_cycles=50, steady_tol=0.05, steady_window=4)


def md(plan, step, **extra):
    return {"plan": plan, "plan_step": step, **extra}


def test_dwell_exact():
    assert list(dwell(400, 2.5, n_cycles=10, torque_nm=5, **STEADY)) == [
        SetTorque(5.0), Configure(400.0, 2.5, 0.0), Output(True), W,
        Record("dwell_400Hz_2p5Vpp", n_cycles=10, metadata=md("dwell", 0)), Output(False)]


def test_amplitude_sweep_defaults_are_seed_002_table_3():
    msgs = list(amplitude_sweep(n_cycles=10, **STEADY))
    assert msgs[0] == SetTorque(5.0)
    assert msgs[1] == Configure(400.0, 1.0)
    records = [m for m in msgs if isinstance(m, Record)]
    assert [r.name for r in records] == ["amplitude_sweep_00_1Vpp", "amplitude_sweep_01_4Vpp",
                                         "amplitude_sweep_02_8Vpp", "amplitude_sweep_03_12Vpp",
                                         "amplitude_sweep_04_16Vpp", "amplitude_sweep_05_20Vpp"]
    assert [m.to_vpp for m in msgs if isinstance(m, Ramp)] == [4.0, 8.0, 12.0, 16.0, 20.0]


def test_amplitude_sweep_exact():
    assert list(amplitude_sweep([1, 4, 8], frequency_hz=400, torque_nm=5, n_cycles=20, **STEADY)) == [
        SetTorque(5.0), Configure(400.0, 1.0), Output(True),
        W, Record("amplitude_sweep_00_1Vpp", n_cycles=20, metadata=md("amplitude_sweep", 0)),
        Ramp(4.0), W, Record("amplitude_sweep_01_4Vpp", n_cycles=20, metadata=md("amplitude_sweep", 1)),
        Ramp(8.0), W, Record("amplitude_sweep_02_8Vpp", n_cycles=20, metadata=md("amplitude_sweep", 2)),
        Output(False)]


def test_torque_series_is_seed_002_table_4_output_off_around_each_torque_change():
    msgs = list(torque_series(n_cycles=20, **STEADY))
    per_torque = []
    for t in (3.0, 5.0, 8.0):
        i = len(per_torque)
        per_torque += [SetTorque(t), Configure(400.0, 20.0), Output(True), W,
                       Record(f"torque_series_{i // 6:02d}_{t:g}Nm", n_cycles=20,
                              metadata=md("torque_series", i // 6)),
                       Output(False)]
    assert msgs == per_torque


def test_friction_test_exact():
    assert list(friction_test(n_cycles=30, **STEADY)) == [
        SetTorque(2.0), Configure(100.0, 20.0), Output(True), W,
        Record("friction_test_100Hz_2Nm", n_cycles=30, metadata=md("friction_test", 0)), Output(False)]


def test_sensor_calibration_exact_and_tagged():
    M = Measure(10)
    extra = {"requested_vpp": 20.0, "range_limited_by": []}
    assert list(sensor_calibration([300, 400], amplitude_vpp=20, torque_nm=5, n_cycles=10, **STEADY)) == [
        SetTorque(5.0), Configure(300.0, 20.0), Output(True), W, M,
        Record("sensor_calibration_00_300Hz", n_cycles=10, metadata={**md("sensor_calibration", 0), **extra}),
        Configure(400.0, 20.0), W, M,
        Record("sensor_calibration_01_400Hz", n_cycles=10, metadata={**md("sensor_calibration", 1), **extra}),
        Output(False)]


def test_sensor_calibration_lowers_the_drive_until_every_channel_is_in_range():
    # reference-force peak / range = 0.065 per Vpp at 200 Hz (clips at 20 Vpp), 0.03 at 400 Hz
    per_vpp = {200.0: 0.065, 400.0: 0.03}
    state = {}

    def respond(msg):
        if isinstance(msg, Configure):
            state.update(f=msg.frequency_hz, vpp=msg.amplitude_vpp)
        elif isinstance(msg, Ramp):
            state["vpp"] = msg.to_vpp
        elif isinstance(msg, WaitSteady):
            return SteadyResult(True, msg.window, 0.0)
        elif isinstance(msg, Measure):
            peak = min(per_vpp[state["f"]] * state["vpp"], 1.0)       # the ADC clips at 1
            return Measurement(state["f"], {}, {}, "force_ref", 20.0,
                               {"force_ref": peak, "disp_1": 0.1})
        return None

    msgs = dry_run(sensor_calibration([200, 400], n_cycles=10, **STEADY), respond)
    recs = [m for m in msgs if isinstance(m, Record)]
    ramps = [m.to_vpp for m in msgs if isinstance(m, Ramp)]
    # 200 Hz: clipped at 20 Vpp -> halve to 10 (0.65 of range) -> within 0.8: stop
    assert ramps == [pytest.approx(10.0)]
    assert recs[0].metadata["range_limited_by"] == ["force_ref"]
    assert recs[1].metadata["range_limited_by"] == []             # 0.6 at 20 Vpp: fine


def test_broadband_log_grid_low_level():
    msgs = list(broadband(f_start_hz=100, f_stop_hz=800, n_frequencies=4, amplitude_vpp=0.2,
                          n_cycles=8, **STEADY))
    freqs = [m.frequency_hz for m in msgs if isinstance(m, Configure)]
    assert freqs == pytest.approx([100, 200, 400, 800])  # log grid: constant ratio 2
    assert all(m.amplitude_vpp == 0.2 for m in msgs if isinstance(m, Configure))
    assert msgs[:3] == [Configure(100.0, 0.2), Output(True), W]
    assert msgs[-1] == Output(False) and msgs.count(Output(True)) == 1
    recs = [m for m in msgs if isinstance(m, Record)]
    assert [r.metadata["plan_step"] for r in recs] == [0, 1, 2, 3]
    assert all(r.metadata["plan"] == "broadband" for r in recs)
    explicit = list(broadband(frequencies_hz=[50, 70], n_cycles=8, **STEADY))
    assert [m.frequency_hz for m in explicit if isinstance(m, Configure)] == [50.0, 70.0]


# ---- step-sine: closed loop, driven by a linear plant F = g(f) * Vpp ---------------------

def plant_responder(gain, max_vpp=20.0):
    state = {"f": None, "vpp": None}

    def respond(msg):
        if isinstance(msg, Configure):
            state["f"], state["vpp"] = msg.frequency_hz, msg.amplitude_vpp
        elif isinstance(msg, Ramp):
            state["vpp"] = msg.to_vpp
        elif isinstance(msg, WaitSteady):
            return SteadyResult(True, msg.window, 0.0)
        elif isinstance(msg, Measure):
            force = gain(state["f"]) * state["vpp"]
            return Measurement(state["f"], {"force_ref": force}, {"force_ref": 0.0}, "force_ref", max_vpp)
        return None

    return respond


def test_step_sine_proportional_control_exact_sequence():
    # g = 10 N/Vpp at 100 Hz, 25 N/Vpp at 110 Hz; target 50 N, step ratio clipped at 2:
    # 100 Hz from 1 Vpp: 10 N -> x2 -> 2 Vpp (20 N) -> x2 -> 4 Vpp (40 N) -> x1.25 -> 5 Vpp;
    # 110 Hz from 5 Vpp: 125 N -> x0.5 -> 2.5 Vpp (62.5 N) -> x0.8 -> 2 Vpp (50 N).
    gains = {100.0: 10.0, 110.0: 25.0}
    msgs = dry_run(step_sine([110, 100], 50.0, initial_vpp=1.0, directions=["up"], n_cycles=30,
                             measure_cycles=5, **STEADY), plant_responder(gains.__getitem__))
    M = Measure(5)
    assert msgs[:12] == [Configure(100.0, 1.0), Output(True), W, M, Ramp(2.0), W, M, Ramp(4.0), W, M,
                         Ramp(5.0), W]
    assert msgs[12] == M and isinstance(msgs[13], Record)
    rec = msgs[13]
    assert rec.name == "step_sine_000_up_100Hz"
    assert rec.metadata["measured_force_n"] == pytest.approx(50.0)
    assert rec.metadata["force_converged"] is True and rec.metadata["corrections"] == 3
    assert msgs[14:] == [Configure(110.0, 5.0), W, M, Ramp(2.5), W, M, Ramp(2.0), W, M, msgs[-2],
                         Output(False)]
    assert msgs[-2].name == "step_sine_001_up_110Hz"


def test_step_sine_up_then_down_keeps_output_on_and_carries_vpp():
    g = lambda f: 10.0 + 0.1 * (f - 100.0)  # noqa: E731
    msgs = dry_run(step_sine([100, 104, 102], 20.0, directions=["up", "down"], n_cycles=30,
                             measure_cycles=5, **STEADY), plant_responder(g))
    recs = [m for m in msgs if isinstance(m, Record)]
    assert [r.metadata["direction"] for r in recs] == ["up"] * 3 + ["down"] * 3
    assert [r.name.split("_")[-1] for r in recs] == ["100Hz", "102Hz", "104Hz", "104Hz", "102Hz", "100Hz"]
    assert msgs.count(Output(True)) == 1 and msgs.count(Output(False)) == 1 and msgs[-1] == Output(False)
    for r in recs:  # converged within tolerance at every step
        assert abs(r.metadata["measured_force_n"] - 20.0) <= 0.03 * 20.0
    # each Configure after the first starts from the Vpp reached at the previous step
    vpp = None
    for m in msgs:
        if isinstance(m, Configure):
            if vpp is not None:
                assert m.amplitude_vpp == vpp
            vpp = m.amplitude_vpp
        elif isinstance(m, Ramp):
            vpp = m.to_vpp


def test_step_sine_saturates_at_the_engine_limit_and_reports_not_converged():
    msgs = dry_run(step_sine([100], 500.0, initial_vpp=4.0, directions=["up"], n_cycles=30,
                             measure_cycles=5, **STEADY), plant_responder(lambda f: 10.0, max_vpp=12.0))
    ramps = [m.to_vpp for m in msgs if isinstance(m, Ramp)]
    assert ramps == [8.0, 12.0]  # x2, then clipped at the limit; no further correction
    rec = next(m for m in msgs if isinstance(m, Record))
    assert rec.metadata["force_converged"] is False
    assert rec.metadata["measured_force_n"] == pytest.approx(120.0)


def test_step_sine_needs_engine_answers():
    with pytest.raises(TypeError, match="Measurement"):
        list(step_sine([100], 10.0))


# ---- parameter validation and load_plan ------------------------------------------------

@pytest.mark.parametrize("call, field", [
    (lambda: dwell(-400, 2), "frequency_hz"),
    (lambda: dwell(400, 2, n_cycles=0), "n_cycles"),
    (lambda: amplitude_sweep([1, -4]), "amplitudes_vpp[1]"),
    (lambda: amplitude_sweep([]), "amplitudes_vpp"),
    (lambda: torque_series([3], frequency_hz=float("nan")), "frequency_hz"),
    (lambda: step_sine([100, 100], 10.0), "frequencies_hz"),
    (lambda: step_sine([100], 10.0, directions=["sideways"]), "directions[0]"),
    (lambda: broadband(f_start_hz=500, f_stop_hz=100), "f_stop_hz"),
    (lambda: dwell(400, 2, bogus=1), "bogus"),
])
def test_bad_parameters_name_the_field(call, field):
    with pytest.raises(InputError) as err:
        call()
    assert err.value.field == field


def test_load_plan_toml_and_json(tmp_path):
    toml = tmp_path / "sweep.toml"
    toml.write_text('plan = "amplitude_sweep"\namplitudes_vpp = [2, 6]\nfrequency_hz = 400\n'
                    'n_cycles = 20\nsteady_max_cycles = 50\nsteady_tol = 0.05\nsteady_window = 4\n')
    assert list(load_plan(toml)) == list(amplitude_sweep([2, 6], n_cycles=20, **STEADY))
    js = tmp_path / "ts.json"
    js.write_text(json.dumps({"plan": "torque_series", "torques_nm": [3, 8], "n_cycles": 5}))
    assert list(load_plan(js)) == list(torque_series([3, 8], n_cycles=5))
    assert list(load_plan({"plan": "friction_test"})) == list(friction_test())
    assert set(PLANS) == {"dwell", "amplitude_sweep", "torque_series", "friction_test",
                          "sensor_calibration", "step_sine", "broadband", "multisine",
                          "swept_sine", "random_noise", "phase_resonance"}


@pytest.mark.parametrize("text, suffix, field", [
    ('frequency_hz = 400\n', ".toml", "plan"),
    ('plan = "warp_drive"\n', ".toml", "plan"),
    ('plan = "dwell"\nfrequency_hz = 400\n', ".toml", "amplitude_vpp"),
    ('plan = "dwell"\nfrequency_hz = 400\namplitude_vpp = "loud"\n', ".toml", "amplitude_vpp"),
    ('plan = "torque_series"\ntorques_nm = [3, 0]\n', ".toml", "torques_nm[1]"),
    ('{"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 2, "n_cylces": 3}', ".json", "n_cylces"),
])
def test_load_plan_errors_name_file_and_field(tmp_path, text, suffix, field):
    p = tmp_path / f"plan{suffix}"
    p.write_text(text)
    with pytest.raises(InputError) as err:
        load_plan(p)
    assert err.value.field == field and err.value.file == str(p)
    assert str(p) in str(err.value) and field in str(err.value)


def test_load_plan_unreadable_files(tmp_path):
    bad = tmp_path / "x.json"
    bad.write_text('{"plan": "dwell",\n "frequency_hz": }')
    with pytest.raises(InputError) as err:
        load_plan(bad)
    assert err.value.line == 2
    bad_toml = tmp_path / "x.toml"
    bad_toml.write_text('plan = "dwell"\nfrequency_hz = = 4\n')
    with pytest.raises(InputError) as err:
        load_plan(bad_toml)
    assert err.value.line == 2 and err.value.file == str(bad_toml)
    with pytest.raises(InputError) as err:
        load_plan({"plan": ["dwell"]})
    assert err.value.field == "plan"
    with pytest.raises(InputError, match="toml or .json"):
        load_plan(tmp_path / "x.yaml")
    with pytest.raises(InputError, match="cannot read"):
        load_plan(tmp_path / "missing.toml")


def test_messages_validate_their_fields():
    for make, field in [(lambda: Configure(0, 1), "frequency_hz"), (lambda: Ramp(-1), "to_vpp"),
                        (lambda: SetTorque(0), "torque_nm"), (lambda: WaitSteady(0, 0.1), "max_cycles"),
                        (lambda: Record("a b", n_cycles=3), "name"),
                        (lambda: Record("ok", n_cycles=3, duration_s=1.0), "n_cycles"),
                        (lambda: Output("yes"), "on")]:
        with pytest.raises(InputError) as err:
            make()
        assert err.value.field == field


# ---- H1 from stepped-sine records -------------------------------------------------------

def sdof_receptance(f, m=1.0, k=4e6, c=60.0):
    w = 2 * np.pi * f
    return 1.0 / (k - m * w ** 2 + 1j * c * w)


def test_frf_h1_recovers_a_known_receptance_under_response_noise():
    rng = np.random.default_rng(1)
    fs = 20000.0
    records = []
    for f in (200.0, 300.0, 318.0, 340.0, 450.0):
        t = np.arange(int(fs * 0.5)) / fs
        force = 5.0 * np.cos(2 * np.pi * f * t + 0.2)
        H = sdof_receptance(f)
        x = np.real(5.0 * H * np.exp(1j * (2 * np.pi * f * t + 0.2)))
        x_noisy = x + rng.normal(0, 0.05 * np.abs(x).max(), x.size)
        records.append((f, force, x_noisy, fs))
    freqs, h1, coh = stepped_frf(records)
    assert list(freqs) == [200.0, 300.0, 318.0, 340.0, 450.0]
    expected = sdof_receptance(freqs)
    assert np.allclose(np.abs(h1), np.abs(expected), rtol=0.01)
    assert np.allclose(np.angle(h1), np.angle(expected), atol=0.01)
    assert np.all(coh > 0.99)
    # resonance near sqrt(k/m)/2pi = 318.3 Hz: the measured peak is there
    assert freqs[np.argmax(np.abs(h1))] == 318.0


def test_frf_h1_coherence_drops_for_an_uncorrelated_response():
    rng = np.random.default_rng(2)
    fs, f = 10000.0, 100.0
    t = np.arange(20000) / fs
    force = np.cos(2 * np.pi * f * t)
    p = frf_h1(force, rng.normal(size=t.size), fs, f, cycles_per_segment=2)
    assert p.n_segments == 100 and p.coherence < 0.1
    with pytest.raises(InputError):
        frf_h1(force, force[:-1], fs, f)
    with pytest.raises(InputError):
        frf_h1(force, force, fs, 6000.0)
    assert math.isclose(frf_h1(force, 3 * force, fs, f).h1.real, 3.0, rel_tol=1e-9)
