"""Broadband excitation from the generator's arbitrary-waveform memory (issue 14 item 5):
waveform design against closed forms, the plans as command lists, the AFG1022 driver on
its pyvisa-sim twin, admission, and the plans end to end on the simulated rig."""

import shutil

import numpy as np
import pytest

from labjoint.acquisition import waveforms as wf
from labjoint.acquisition.admission import check_plan
from labjoint.acquisition.engine import RunEngine
from labjoint.acquisition.messages import LoadWaveform, Output, Record, WaitSteady
from labjoint.acquisition.plans import load_plan
from labjoint.acquisition.plans_waveform import multisine, random_noise, swept_sine
from labjoint.acquisition.rig import open_rig
from labjoint.acquisition.safety import LimitTrip, check_settings
from labjoint.config import CONFIG_DIR, LimitsConfig, load_config
from labjoint.errors import HardwareError, InputError
from labjoint.hardware import visa_twin
from labjoint.hardware.afg1022 import AFG1022, codes_14bit
from labjoint.hardware.interfaces import GeneratorSettings
from labjoint.hardware.sim.devices import MemoryGenerator
from labjoint.signal.excitation import detect_excitation

RES = "USB0::0x0699::0x0353::SIM0001::INSTR"
FS = 25000.0


def spectrum(x):
    return np.abs(np.fft.rfft(x)) / x.size


# ---- design -----------------------------------------------------------------------------

@pytest.mark.parametrize("phases", ["random", "schroeder"])
def test_multisine_puts_equal_power_on_the_designed_lines_and_nothing_elsewhere(phases):
    w = wf.multisine(f_min_hz=20, f_max_hz=200, resolution_hz=2, phases=phases, crest_iterations=10)
    a = spectrum(w.points)
    k = np.round(np.array(w.lines_hz) / 2).astype(int)
    assert w.period_s == 0.5 and len(k) == 91 and k[0] == 10 and k[-1] == 100
    assert np.ptp(a[k]) < 1e-9 * a[k].max()                  # flat amplitude spectrum
    off = np.delete(a, k)
    assert off.max() < 1e-9 * a[k].max()                      # no power off the lines
    assert np.max(np.abs(w.points)) == pytest.approx(1.0, abs=1e-15)   # peak normalised


def test_crest_factor_control_lowers_the_crest_factor_of_a_random_phase_multisine():
    raw = wf.multisine(f_min_hz=10, f_max_hz=500, resolution_hz=1, crest_iterations=0, seed=3)
    low = wf.multisine(f_min_hz=10, f_max_hz=500, resolution_hz=1, crest_iterations=40, seed=3)
    schroeder = wf.multisine(f_min_hz=10, f_max_hz=500, resolution_hz=1, phases="schroeder")
    assert raw.crest_factor > 2.8                 # a random-phase multisine: about 3-4
    assert low.crest_factor < 0.8 * raw.crest_factor
    assert schroeder.crest_factor < 2.2           # Schroeder: about 1.7 for a flat spectrum
    assert low.crest_factor == pytest.approx(wf.crest_factor(low.points))


def test_odd_and_random_odd_lines_leave_detection_lines_free():
    odd = wf.multisine_lines(1, 40, 1, "odd")
    assert set(odd) == set(range(1, 41, 2))
    ro = wf.multisine_lines(1, 40, 1, "random_odd", seed=2)
    assert set(ro) < set(odd) and len(ro) == 15     # one of every group of 4 left out


def test_capacity_of_the_memory_is_stated_and_enforced():
    assert wf.max_lines(8192) == 1023 and wf.max_lines(8192, oversampling=1) == 4095
    wf.multisine(f_min_hz=1, f_max_hz=1024, resolution_hz=1)          # 8192 / (2 x 4) = 1024 Hz
    with pytest.raises(InputError, match="at most 1023 lines") as err:
        wf.multisine(f_min_hz=1, f_max_hz=1100, resolution_hz=1)
    assert err.value.field == "f_max_hz"
    with pytest.raises(InputError) as err:
        wf.multisine(f_min_hz=1, f_max_hz=10, resolution_hz=1, lines_hz=[2.0, 3.5])
    assert err.value.field == "lines_hz"
    with pytest.raises(InputError) as err:
        wf.swept_sine(f_start_hz=10, f_stop_hz=100, period_s=0.0)
    assert err.value.field == "period_s"
    with pytest.raises(InputError, match="lower f_stop_hz or shorten the period") as err:
        wf.swept_sine(f_start_hz=10, f_stop_hz=6000, period_s=1.0)
    assert err.value.field == "f_stop_hz"


@pytest.mark.parametrize("law", ["log", "linear"])
def test_a_sweep_covers_its_band_and_repeats_without_a_step(law):
    w = wf.swept_sine(f_start_hz=20, f_stop_hz=400, period_s=2.0, law=law)
    a2 = spectrum(w.points) ** 2
    f = np.arange(a2.size) / w.period_s
    in_band = a2[(f >= 18) & (f <= 420)].sum() / a2.sum()
    assert in_band > 0.98
    assert abs(w.points[-1] - w.points[0]) < 1e-3          # faded: no jump at the wrap
    assert w.band_hz == (20.0, 400.0)


def test_codes_map_the_peak_to_full_scale_symmetrically():
    assert codes_14bit([-3.0, 3.0, 0.0]).tolist() == [0, 16382, 8191]
    with pytest.raises(InputError, match="2..8192"):
        codes_14bit([1.0])
    with pytest.raises(InputError, match="finite"):
        codes_14bit([0.0, np.nan])


# ---- plans as lists of commands ---------------------------------------------------------

def test_multisine_plan_is_exactly_load_on_settle_record_off():
    msgs = list(multisine(f_min_hz=50, f_max_hz=200, resolution_hz=5, amplitude_vpp=2, n_periods=4,
                          steady_max_periods=8, steady_tol=0.05, steady_window=3))
    w = wf.multisine(f_min_hz=50, f_max_hz=200, resolution_hz=5, crest_iterations=20)
    assert msgs == [LoadWaveform(tuple(w.points), 5.0, 2.0, (50.0, 200.0)), Output(True),
                    WaitSteady(max_cycles=8, tol=0.05, window=3),
                    Record("multisine_50-200Hz_2Vpp", n_cycles=4,
                           metadata={"plan": "multisine", "plan_step": 0}),
                    Output(False)]
    assert msgs[0].excitation["kind"] == "multisine" and msgs[0].excitation["n_lines"] == 31


def test_plans_refuse_bad_parameters_when_called_naming_the_parameter():
    with pytest.raises(InputError) as err:
        load_plan({"plan": "multisine", "f_min_hz": 100, "f_max_hz": 50})
    assert err.value.field == "f_max_hz"
    with pytest.raises(InputError) as err:
        load_plan({"plan": "swept_sine", "law": "cubic"})
    assert err.value.field == "law"
    with pytest.raises(InputError) as err:
        load_plan({"plan": "random_noise", "n_points": 10000})
    assert err.value.field == "n_points"


def test_admission_checks_the_waveform_band_not_its_repetition_rate():
    cfg = load_config()                          # 1 Hz - 5 kHz, 50 kS/s by default
    check_plan({"plan": "multisine", "f_min_hz": 50, "f_max_hz": 1000, "resolution_hz": 5}, cfg)
    with pytest.raises(InputError, match="band reaches 6000 Hz exceeds max_frequency_hz"):
        check_plan({"plan": "swept_sine", "f_start_hz": 100, "f_stop_hz": 6000, "sweep_s": 0.1}, cfg)
    slow = load_config(overrides={"daq": {"sample_rate_hz": 2000.0}})
    with pytest.raises(InputError, match="Nyquist"):
        check_plan({"plan": "random_noise", "f_min_hz": 50, "f_max_hz": 1500, "period_s": 0.5}, slow)
    with pytest.raises(LimitTrip, match="needs its band"):
        check_settings(GeneratorSettings(1.0, 2.0, shape="user"), LimitsConfig())


# ---- generators ---------------------------------------------------------------------------

@pytest.fixture
def lib(tmp_path):
    path = tmp_path / "afg1022-sim.yaml"
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", path)
    return f"{path}@sim"


def test_afg1022_loads_a_waveform_as_a_binary_block_and_plays_it(lib):
    w = wf.multisine(f_min_hz=10, f_max_hz=100, resolution_hz=2)
    with AFG1022.open(RES, lib, timeout_ms=200) as gen:
        with pytest.raises(HardwareError, match="no arbitrary waveform loaded"):
            gen.apply_waveform(2.0, 1.0)
        assert gen.load_waveform(3.0 * w.points) == 8192
        np.testing.assert_allclose(gen.waveform(), w.points, atol=1.0 / 8191)  # 14-bit codes
        got = gen.apply_waveform(2.0, 4.0, 0.5)
        assert (got.shape, got.frequency_hz, got.amplitude_vpp, got.offset_v) == ("user", 2.0, 4.0, 0.5)
        assert gen.apply(400.0, 1.0).shape == "sine"


def test_the_twin_refuses_a_malformed_block_like_the_instrument():
    good = visa_twin.HEADER + b"#14" + bytes([0x3F, 0xFE, 0x00, 0x00]) + b"\n"
    assert visa_twin.parse_block(good).tolist() == [16382, 0]
    for bad in (b"#15" + bytes(5), b"#2" + b"4" + bytes(4), b"#14" + bytes([0xFF, 0xFF, 0, 0]),
                b"#12" + bytes(2), b"4" + bytes(4)):
        assert visa_twin.parse_block(visa_twin.HEADER + bad + b"\n") is None


def test_the_memory_generator_plays_the_same_interface():
    g = MemoryGenerator()
    with pytest.raises(HardwareError):
        g.apply_waveform(1.0, 1.0)
    g.load_waveform(np.array([0.0, 2.0, -1.0]))
    assert g.waveform().tolist() == [0.0, 1.0, -0.5]
    assert g.apply_waveform(3.0, 2.0).shape == "user"


# ---- end to end on the simulated rig ------------------------------------------------------

class Clock:
    t = 0.0

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.t += dt


def run_plan(plan):
    rig = open_rig(load_config(overrides={"daq": {"sample_rate_hz": FS, "block_samples": 1250}}))
    docs, drive = [], []

    def keep(name, doc):      # the generator's output (true state) beside each recorded block
        docs.append((name, doc))
        if name == "block":
            drive.append(rig.sim.true_state().drive_v.copy())

    clock = Clock()
    engine = RunEngine(rig.generator, rig.daq, rig.config.limits, [keep],
                       clock=clock, sleep=clock.sleep, rig=rig.sim, config=rig.config)
    try:
        result = engine.run(plan)
    finally:
        rig.close()
    start = next(d for n, d in docs if n == "start")
    volts = np.concatenate([d.volts for n, d in docs if n == "block"], axis=1)
    return result, start, volts, [c.name for c in rig.daq.channels], np.concatenate(drive)


def test_a_multisine_plan_records_a_multisine_on_the_simulated_rig():
    result, start, volts, names, drive = run_plan(
        multisine(f_min_hz=50, f_max_hz=500, resolution_hz=5, amplitude_vpp=2.0, n_periods=5))
    assert result.status == "complete"
    md = start.metadata
    assert md["excitation"]["kind"] == "multisine" and md["generator"]["shape"] == "user"
    assert md["frequency_hz"] == 5.0 and volts.shape[1] == 5 * int(FS / 5)
    assert np.max(np.abs(drive)) == pytest.approx(1.0, rel=1e-3)        # peak = Vpp / 2
    found = detect_excitation(volts[names.index("force_ref")], FS, md)
    assert found.kind == "multisine" and found.period_s == pytest.approx(0.2, rel=1e-3)
    assert set(np.arange(50.0, 501.0, 5.0)) <= set(np.round(found.lines_hz, 6))


def test_a_swept_sine_and_random_noise_play_through_the_same_path():
    result, start, volts, names, drive = run_plan(
        swept_sine(f_start_hz=100, f_stop_hz=600, sweep_s=0.5, amplitude_vpp=2.0, n_periods=2))
    assert result.status == "complete" and start.metadata["excitation"]["kind"] == "swept_sine"
    found = detect_excitation(drive, FS)     # the generator's output: two sweeps, repeated
    assert found.kind == "multisine" and found.period_s == pytest.approx(0.5, rel=1e-3)
    assert abs(np.max(np.abs(drive)) - 1.0) < 1e-3
    result, start, volts, names, _ = run_plan(
        random_noise(f_min_hz=50, f_max_hz=800, period_s=1.0, amplitude_vpp=2.0))
    assert result.status == "complete"
    assert detect_excitation(volts[names.index("force_ref")], FS).kind == "random"


def test_the_engine_refuses_to_swap_waveforms_under_a_live_output():
    w = wf.multisine(f_min_hz=50, f_max_hz=200, resolution_hz=5)
    msg = LoadWaveform(tuple(w.points), 5.0, 1.0, w.band_hz)

    def plan():
        yield msg
        yield Output(True)
        yield msg

    with pytest.raises(InputError, match="output off before loading a waveform"):
        run_plan(plan())


@pytest.mark.parametrize("name", ["multisine", "swept_sine", "random_noise"])
def test_every_broadband_plan_with_its_defaults_is_admitted_on_the_default_rig(name):
    check_plan({"plan": name}, load_config())


def test_simulate_records_a_broadband_plan_and_says_why_it_is_not_loop_analysed(tmp_path, capsys):
    import json

    from labjoint.cli.main import main

    plan = tmp_path / "ms.toml"
    plan.write_text('plan = "random_noise"\nf_min_hz = 100\nf_max_hz = 800\nperiod_s = 0.5\n')
    assert main(["simulate", "--plan", str(plan), "--out", str(tmp_path / "d"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "complete" and out["runs"] == []
    (skip,) = out["not_analysed"]
    assert "random" in skip["error"] and "labjoint fit" in skip["error"]
