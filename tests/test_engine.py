"""RunEngine mechanics on a small linear plant (fake generator + DAQ), fake clock/sleep.

The plant: every channel is a sine at the generator's frequency whose amplitude follows
gain * Vpp (output on) through a first-order envelope with time constant ``tau_s``, so
steady-state detection, ramps, limits and faults can be checked against closed forms.
The physics-based simulated rig is exercised in test_engine_sim.py.
"""

import math
import threading
from datetime import datetime

import numpy as np
import pytest

from labjoint import __version__
from labjoint.acquisition.engine import FLOOR_VPP, RunEngine
from labjoint.acquisition.gate import TorqueGate
from labjoint.acquisition.messages import (Checkpoint, Configure, Measure, Output, Pause, Ramp,
                                           Record, SetTorque, WaitSteady)
from labjoint.acquisition.online import fundamental
from labjoint.acquisition.plans import amplitude_sweep, step_sine, torque_series
from labjoint.config import LimitsConfig, load_config
from labjoint.errors import BufferOverrun, InputError, InstrumentTimeout
from labjoint.hardware.interfaces import DAQ, GeneratorSettings, SignalGenerator

FS = 25000.0
CONFIG = load_config()
#: SI amplitude per Vpp on each channel (disp_2 in antiphase), and the sensor sensitivities.
GAIN = {"force_ref": 10.0, "disp_1": 1e-6, "disp_2": -1e-6, "shear_nc": 8.0}


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.t += dt


class FakeGenerator(SignalGenerator):
    def __init__(self, clock, fail=None):
        self.clock, self.fail = clock, fail
        self.s = GeneratorSettings(1000.0, 1.0, 0.0, False)
        self.events = []

    def identify(self):
        return "FAKE,GEN"

    def apply(self, frequency_hz, amplitude_vpp, offset_v=0.0):
        if self.fail:
            self.fail("apply", self)
        self.s = GeneratorSettings(frequency_hz, amplitude_vpp, offset_v, self.s.output)
        self.events.append(("apply", self.clock(), amplitude_vpp, self.s.output))
        return self.s

    def set_amplitude(self, amplitude_vpp):
        return self.apply(self.s.frequency_hz, amplitude_vpp, self.s.offset_v)

    def set_output(self, on):
        self.events.append(("output", self.clock(), bool(on), threading.current_thread().name))
        if self.fail and on:
            self.fail("output", self)
        self.s = GeneratorSettings(self.s.frequency_hz, self.s.amplitude_vpp, self.s.offset_v, bool(on))

    def read_settings(self):
        if self.fail:
            self.fail("read", self)
        return self.s

    def close(self):
        self.set_output(False)

    def vpp_history(self):
        return [(t, v) for kind, t, v, *_ in self.events if kind == "apply"]


class FakeDAQ(DAQ):
    """Linear plant read through the generator's read-back every block (like the sim)."""

    def __init__(self, generator, tau_s=0.0, noise=0.0, gain_of_f=lambda f: 1.0, on_read=None):
        self.gen, self.tau_s, self.noise, self.gain_of_f = generator, tau_s, noise, gain_of_f
        self.on_read = on_read
        self._channels = CONFIG.daq.specs()
        self._n = 0
        self._abs = 0
        self.env = np.zeros(len(self._channels))
        self.rng = np.random.default_rng(0)
        self.starts = 0

    def configure(self, channels, sample_rate_hz):
        return FS

    @property
    def channels(self):
        return self._channels

    @property
    def sample_rate_hz(self):
        return FS

    def start(self):
        self._n = 0
        self.starts += 1

    def read(self, n_samples, out=None):
        if self.on_read:
            self.on_read(self)
        s = self.gen.read_settings()
        vpp = s.amplitude_vpp if s.output else 0.0
        target = np.array([GAIN[c.name] for c in self._channels]) * vpp * self.gain_of_f(s.frequency_hz)
        k = np.arange(1, n_samples + 1)
        if self.tau_s > 0:
            decay = np.exp(-k / (FS * self.tau_s))
            env = target[:, None] + (self.env - target)[:, None] * decay[None, :]
        else:
            env = np.repeat(target[:, None], n_samples, axis=1)
        self.env = env[:, -1].copy()
        phase = 2 * np.pi * s.frequency_hz * (self._abs + k - 1) / FS
        si = env * np.cos(phase)[None, :]
        volts = si / np.array([c.sensitivity for c in self._channels])[:, None]
        if self.noise:
            volts = volts + self.rng.normal(0, self.noise, volts.shape)
        self._n += n_samples
        self._abs += n_samples
        return volts

    @property
    def samples_read(self):
        return self._n

    def stop(self):
        pass

    def close(self):
        pass


class FakeSimRig:
    def __init__(self, torque_nm=5.0):
        self.torque_nm = torque_nm
        self.torques = []

    def set_torque(self, nm):
        self.torque_nm = nm
        self.torques.append(nm)


class Collector:
    def __init__(self):
        self.docs = []

    def __call__(self, name, doc):
        self.docs.append((name, doc))

    def open_blocks(self):
        """Blocks emitted into the run that is open now (-1 if none is open)."""
        n = -1
        for name, _ in self.docs:
            n = 0 if name == "start" else -1 if name == "stop" else n + (name == "block" and n >= 0)
        return n

    def runs(self):
        out = {}
        for name, doc in self.docs:
            out.setdefault(doc.uid, []).append((name, doc))
        return list(out.values())


def make(limits=None, tau_s=0.0, sim=True, fail=None, gate=None, on_read=None, **daq_kw):
    """Engine on the fake plant; ``on_read(collector)`` runs before every DAQ read."""
    clock = Clock()
    col = Collector()
    gen = FakeGenerator(clock, None if fail is None else (lambda kind, g: fail(kind, g, col)))
    daq = FakeDAQ(gen, tau_s=tau_s, on_read=None if on_read is None else (lambda d: on_read(col)), **daq_kw)
    engine = RunEngine(gen, daq, limits or LimitsConfig(), [col], clock=clock, sleep=clock.sleep,
                       torque_gate=gate, rig=FakeSimRig() if sim else None, config=CONFIG,
                       block_samples=1250)
    return engine, gen, daq, col


def amplitude(volts, channel, f, first=0):
    i = [c.name for c in CONFIG.daq.specs()].index(channel)
    return abs(fundamental(volts[i:i + 1], FS, f, first)[0])


def joined(run):
    blocks = [d for n, d in run if n == "block"]
    return np.concatenate([b.volts for b in blocks], axis=1), blocks


# ---- a normal amplitude sweep --------------------------------------------------------

def test_amplitude_sweep_three_runs_documents_and_metadata():
    engine, gen, daq, col = make(tau_s=0.004)
    result = engine.run(amplitude_sweep([2, 6, 10], frequency_hz=400, torque_nm=4, n_cycles=40,
                                        steady_max_cycles=200, steady_tol=0.01, steady_window=6),
                        name_prefix="t")
    assert result.status == "complete" and len(result.runs) == 3
    runs = col.runs()
    assert len(runs) == 3
    n_expected = math.ceil(40 * FS / 400)
    for run, vpp, step in zip(runs, [2.0, 6.0, 10.0], range(3)):
        names = [n for n, _ in run]
        assert names[0] == "start" and names[1] == "marker" and names[-1] == "stop"
        start, stop = run[0][1], run[-1][1]
        assert start.name == f"t_amplitude_sweep_{step:02d}_{vpp:g}Vpp"
        m = start.metadata
        assert m["plan"] == "amplitude_sweep" and m["plan_step"] == step
        assert m["frequency_hz"] == 400.0 and m["excitation_vpp"] == vpp and m["offset_v"] == 0.0
        assert m["torque_nm"] == 4.0 and m["normal_force_n"] == pytest.approx(4.0 * 478.0)
        assert m["sample_rate_hz"] == FS and start.sample_rate_hz == FS
        assert m["generator"]["amplitude_vpp"] == vpp and m["generator"]["output"] is True
        assert m["software_version"] == __version__
        assert m["displacement_channels"] == ["disp_1", "disp_2"]
        assert m["joint_force_channel"] == "shear_nc" and m["reference_force_channel"] == "force_ref"
        assert m["rig_backend"] == "sim"
        assert m["steady"]["reached"] is True and run[1][1].name == "steady"
        t0 = datetime.fromisoformat(m["start_time"])
        t1 = datetime.fromisoformat(stop.end_time)
        assert t0.utcoffset().total_seconds() == 0 and t1 >= t0
        assert stop.status == "complete" and stop.n_samples == n_expected
        volts, blocks = joined(run)
        firsts = [b.first_sample for b in blocks]
        assert firsts[0] == 0
        assert all(b.first_sample + b.volts.shape[1] == nb.first_sample for b, nb in zip(blocks, blocks[1:]))
        assert volts.shape == (4, n_expected)
        # the recorded displacement is the steady response to this run's excitation
        assert amplitude(volts, "disp_1", 400.0) == pytest.approx(1e-6 * vpp / 1.25e-5, rel=1e-3)
    assert gen.s.output is False
    assert engine.rig.torques == [4.0]


def test_ramps_never_step_faster_than_the_rate_and_output_switches_at_the_floor():
    limits = LimitsConfig(ramp_vpp_per_s=40.0)
    engine, gen, daq, col = make(limits=limits)
    plan = [Configure(400, 15), Output(True), Record("a", n_cycles=10), Ramp(3), Ramp(20),
            Record("b", n_cycles=10), Configure(450, 20), Output(False)]
    assert engine.run(plan, name_prefix="").status == "complete"
    hist = gen.vpp_history()
    v = [x for _, x in hist]
    assert max(v) == 20.0 and 15.0 in v and 3.0 in v
    for (t0, v0), (t1, v1) in zip(hist, hist[1:]):
        assert abs(v1 - v0) <= 40.0 * (t1 - t0) + 1e-9, (t0, v0, t1, v1)
    ons = [i for i, e in enumerate(gen.events) if e[0] == "output" and e[2]]
    offs = [i for i, e in enumerate(gen.events) if e[0] == "output" and not e[2]]
    for i in ons + offs:  # every switching happens with the amplitude parked at the floor
        prev = [e for e in gen.events[:i] if e[0] == "apply"][-1]
        assert prev[2] == FLOOR_VPP
    # the ramp from the floor to 15 Vpp took (15 - floor) / 40 s on the engine's clock
    t_on = gen.events[ons[0]][1]
    t_15 = next(t for t, x in hist if x == 15.0)
    assert t_15 - t_on == pytest.approx((15 - FLOOR_VPP) / 40.0, abs=0.051)
    # a frequency change at 20 Vpp is applied without touching the amplitude
    assert gen.s.frequency_hz == 450.0 and gen.s.output is False


def test_a_plan_starting_with_the_output_on_ramps_from_where_the_generator_is():
    engine, gen, daq, col = make()
    gen.s = GeneratorSettings(400.0, 12.0, 0.0, True)  # left on by someone else
    assert engine.run([Configure(400, 4), Record("r", n_cycles=10)]).status == "complete"
    hist = gen.vpp_history()
    assert hist[0][1] == pytest.approx(10.0) and 4.0 in [v for _, v in hist]  # 12 -> 10 -> ... -> 4
    for (t0, v0), (t1, v1) in zip(hist, hist[1:]):
        assert abs(v1 - v0) <= 40.0 * (t1 - t0) + 1e-9
    assert col.docs[0][1].metadata["excitation_vpp"] == 4.0 and gen.s.output is False


def test_steady_state_reached_after_the_closed_form_number_of_cycles():
    # envelope a_k = A (1 - exp(-k / K)) with K = tau f cycles: its drift across a window
    # of w cycles ending at cycle k is about (w - 1) / K exp(-(k - (w - 1) / 2) / K)
    # (slope at the window's centre), which falls under tol at
    # k = (w - 1) / 2 + K ln((w - 1) / (K tol))
    tau, f, w, tol = 0.025, 400.0, 10, 0.02
    engine, gen, daq, col = make(tau_s=tau, limits=LimitsConfig(ramp_vpp_per_s=1e6))  # a step
    engine.block_samples = 125
    answers = []

    def plan():
        yield Configure(f, 10)
        yield Output(True)
        answers.append((yield WaitSteady(max_cycles=300, tol=tol, window=w)))
        yield Output(False)

    assert engine.run(plan()).status == "complete"
    res = answers[0]
    K = tau * f
    k_expected = (w - 1) / 2 + K * math.log((w - 1) / (K * tol))
    assert res.reached and abs(res.cycles - k_expected) <= 3, (res.cycles, k_expected)
    assert res.amplitude_m["disp_1"] == pytest.approx(10e-6, rel=tol)


def test_not_steady_within_max_cycles_is_recorded_in_metadata():
    engine, gen, daq, col = make(tau_s=1.0)
    plan = [Configure(400, 10), Output(True), WaitSteady(max_cycles=20, tol=0.001, window=5),
            Record("r", n_cycles=10), Output(False)]
    assert engine.run(plan).status == "complete"
    start = col.docs[0][1]
    assert start.metadata["steady"]["reached"] is False and start.metadata["steady"]["cycles"] >= 20


def test_measure_answers_amplitudes_in_si_units():
    engine, gen, daq, col = make(noise=1e-4)
    got = []

    def plan():
        yield Configure(300, 8)
        yield Output(True)
        got.append((yield Measure(n_cycles=30)))

    assert engine.run(plan()).status == "complete"
    m = got[0]
    assert m.frequency_hz == 300.0 and m.max_vpp == 20.0
    assert m.reference_force_n == pytest.approx(10.0 * 8, rel=1e-3)
    assert m.amplitude["disp_2"] == pytest.approx(8e-6, rel=1e-3)
    assert abs(abs(m.phase_rad["disp_1"] - m.phase_rad["disp_2"]) - math.pi) < 1e-3
    assert gen.s.output is False  # switched off at the end although the plan did not


def test_step_sine_on_the_plant_holds_the_force_amplitude():
    res = lambda f: 1.0 / math.sqrt((1 - (f / 420.0) ** 2) ** 2 + (0.05 * f / 420.0) ** 2)  # noqa: E731
    engine, gen, daq, col = make(tau_s=0.002, gain_of_f=res)
    result = engine.run(step_sine([380, 400, 420, 440], 30.0, initial_vpp=1.0, directions=["up", "down"],
                                  n_cycles=20, measure_cycles=10, steady_max_cycles=100,
                                  steady_tol=0.01, steady_window=5))
    assert result.status == "complete" and len(result.runs) == 8
    for run in col.runs():
        start = run[0][1]
        volts, _ = joined(run)
        f = start.metadata["frequency_hz"]
        force = amplitude(volts, "force_ref", f) * 50.0
        assert force == pytest.approx(30.0, rel=0.03)
        assert start.metadata["excitation_vpp"] == pytest.approx(30.0 / (10.0 * res(f)), rel=0.03)


# ---- limits ---------------------------------------------------------------------------

def test_limit_during_a_record_ramps_down_and_stops_with_status_limit():
    # relative displacement disp_1 - disp_2 = 2 um/Vpp: fine at 4 Vpp, over 12 um at 8 Vpp
    limits = LimitsConfig(max_displacement_m=12e-6)
    engine, gen, daq, col = make(limits=limits)
    plan = [Configure(400, 4), Output(True), Record("ok", n_cycles=10), Ramp(8),
            Record("too_far", n_cycles=100), Output(False)]
    result = engine.run(plan, name_prefix="")
    assert result.status == "limit" and "max_displacement_m" in result.reason
    run = col.runs()[1]
    stop = run[-1][1]
    assert stop.status == "limit" and "disp_1-disp_2" in stop.reason and "1.6e-05" in stop.reason
    marker = [d for n, d in run if n == "marker" and d.name == "limit"][0]
    assert marker.data["limit"] == "max_displacement_m" and marker.data["value"] == pytest.approx(16e-6, rel=1e-3)
    assert marker.data["channel"] == "disp_1-disp_2" and marker.sample == marker.data["index"] < 1250
    assert stop.n_samples == 1250  # the block that tripped is kept, nothing after it
    # amplitude ramped down (rate-limited) before the output went off
    hist = gen.vpp_history()
    i_top = max(i for i, (_, v) in enumerate(hist) if v == 8.0)
    down = [v for _, v in hist[i_top:]]
    assert down[-1] == FLOOR_VPP and all(b < a for a, b in zip(down, down[1:])) and len(down) > 2
    assert gen.events[-1][:1] == ("output",) and gen.events[-1][2] is False


def test_limit_on_requested_settings_never_reaches_the_generator():
    engine, gen, daq, col = make(limits=LimitsConfig(max_vpp=10.0, max_frequency_hz=1000.0))
    r = engine.run([Configure(400, 12), Output(True)])
    assert r.status == "limit" and "max_vpp" in r.reason
    r = engine.run([Configure(400, 5), Output(True), Configure(1500, 5)])
    assert r.status == "limit" and "max_frequency_hz" in r.reason
    assert max(v for _, v in gen.vpp_history()) == 5.0 and gen.s.frequency_hz == 400.0
    assert gen.s.output is False and col.docs == []


def test_limit_while_waiting_for_steady_state_ends_the_plan():
    engine, gen, daq, col = make(limits=LimitsConfig(max_force_n=100.0))
    result = engine.run(amplitude_sweep([4, 12], n_cycles=10, steady_max_cycles=50,
                                        steady_tol=0.05, steady_window=4))
    assert result.status == "limit" and "force_ref" in result.reason and "max_force_n" in result.reason
    assert [r.status for r in result.runs] == ["complete"]
    assert gen.s.output is False


# ---- faults ---------------------------------------------------------------------------

def test_buffer_overrun_fails_the_run_keeping_the_data():
    def on_read(col):
        if col.open_blocks() == 2:
            raise BufferOverrun("fake overrun: samples lost")

    engine, gen, daq, col = make(on_read=on_read)
    plan = [Configure(400, 5), Output(True), Record("r", n_cycles=200), Output(False)]
    result = engine.run(plan)
    assert result.status == "failed" and "BufferOverrun" in result.reason
    run = col.runs()[0]
    stop = run[-1][1]
    assert stop.status == "failed" and "BufferOverrun" in stop.reason
    volts, blocks = joined(run)
    assert volts.shape[1] == 2500 == stop.n_samples  # every block before the fault
    fault = [d for n, d in run if n == "marker"][-1]
    assert fault.name == "fault" and fault.sample == 2500 and "BufferOverrun" in fault.data["error"]
    assert gen.s.output is False and gen.vpp_history()[-1][1] == FLOOR_VPP  # ramped, then off


def test_generator_timeout_mid_plan_fails_and_still_attempts_output_off():
    calls = {"n": 0, "failed_at": None}

    def fail(kind, gen, col):
        if kind == "apply":
            calls["n"] += 1
            if calls["failed_at"] is None and gen.s.amplitude_vpp >= 10.0:  # mid-way up to 20 Vpp
                calls["failed_at"] = calls["n"]
                raise InstrumentTimeout("fake: no answer to AMPLitude")

    engine, gen, daq, col = make(fail=fail)
    result = engine.run(amplitude_sweep([2, 20], n_cycles=10, steady_max_cycles=20,
                                        steady_tol=0.05, steady_window=4))
    assert result.status == "failed" and "InstrumentTimeout" in result.reason
    assert gen.events[-1][0] == "output" and gen.events[-1][2] is False
    # no ramp-down was attempted through the faulty generator after the timeout
    assert calls["n"] == calls["failed_at"]
    assert [r.status for r in result.runs] == ["complete"]


def test_generator_timeout_during_a_record_fails_that_run():
    def fail(kind, gen, col):
        if kind == "read" and col.open_blocks() >= 2:
            raise InstrumentTimeout("fake: read-back timed out")

    engine, gen, daq, col = make(fail=fail)
    result = engine.run([Configure(400, 5), Output(True), Record("r", n_cycles=100)])
    assert result.status == "failed"
    stop = col.docs[-1][1]
    assert stop.status == "failed" and "InstrumentTimeout" in stop.reason and stop.n_samples == 2500
    assert gen.events[-1][0] == "output" and gen.events[-1][2] is False


def test_exception_in_plan_code_switches_output_off_and_propagates():
    engine, gen, daq, col = make()

    def plan():
        yield Configure(400, 10)
        yield Output(True)
        yield Record("r", n_cycles=10)
        raise ZeroDivisionError("bug in plan")

    with pytest.raises(ZeroDivisionError):
        engine.run(plan())
    assert gen.s.output is False and gen.vpp_history()[-1][1] == FLOOR_VPP
    assert engine.state == "idle"
    with pytest.raises(InputError, match="offset"):  # a plan error the engine detects
        engine.run([Configure(400, 10), Output(True), Configure(400, 10, offset_v=1.0)])
    assert gen.s.output is False


def test_keyboard_interrupt_aborts_the_run_output_off_and_reraises():
    def on_read(col):
        if col.open_blocks() == 2:
            raise KeyboardInterrupt

    engine, gen, daq, col = make(on_read=on_read)
    with pytest.raises(KeyboardInterrupt):
        engine.run([Configure(400, 10), Output(True), Record("r", n_cycles=100)])
    stop = col.docs[-1][1]
    assert stop.status == "aborted" and "KeyboardInterrupt" in stop.reason
    assert gen.s.output is False and gen.vpp_history()[-1][1] == 10.0  # off at once, no ramp


def test_emergency_stop_from_another_thread():
    reading, release = threading.Event(), threading.Event()

    def on_read(col):
        if col.open_blocks() == 3:
            reading.set()
            assert release.wait(5)

    engine, gen, daq, col = make(on_read=on_read)
    out = {}
    t = threading.Thread(target=lambda: out.update(r=engine.run(
        [Configure(400, 10), Output(True), Record("r", n_cycles=1000), Output(False)])), name="engine")
    t.start()
    assert reading.wait(5)
    engine.emergency_stop("operator pressed stop")
    assert gen.s.output is False  # off before the engine thread even noticed
    off = [e for e in gen.events if e[0] == "output"][-1]
    assert off[3] == threading.current_thread().name and gen.vpp_history()[-1][1] == 10.0
    release.set()
    t.join(5)
    assert out["r"].status == "aborted" and out["r"].reason == "operator pressed stop"
    stop = col.docs[-1][1]
    # the read in flight when the stop came completes and is kept: 4 blocks
    assert stop.status == "aborted" and stop.reason == "operator pressed stop" and stop.n_samples == 5000
    assert not [e for e in gen.events if e[0] == "output" and e[2] and e[1] > off[1]]


# ---- torque and operator --------------------------------------------------------------

def test_torque_series_on_the_sim_applies_each_torque_with_output_off():
    engine, gen, daq, col = make()
    torques_seen = []
    engine.rig.set_torque = lambda nm: torques_seen.append((nm, gen.s.output))
    r = engine.run(torque_series([3, 5, 8], n_cycles=10, steady_max_cycles=20, steady_tol=0.05,
                                 steady_window=4))
    assert r.status == "complete"
    assert torques_seen == [(3.0, False), (5.0, False), (8.0, False)]
    starts = [d for n, d in col.docs if n == "start"]
    assert [s.metadata["torque_nm"] for s in starts] == [3.0, 5.0, 8.0]
    assert [s.metadata["normal_force_n"] for s in starts] == pytest.approx([1434.0, 2390.0, 3824.0])


def test_torque_series_on_a_real_rig_waits_on_the_gate_until_continued():
    gate = TorqueGate(poll_s=0.01)
    engine, gen, daq, col = make(sim=False, gate=gate)
    out = {}
    t = threading.Thread(target=lambda: out.update(r=engine.run(
        torque_series([3, 5], n_cycles=10, steady_max_cycles=20, steady_tol=0.05, steady_window=4))))
    t.start()
    seen = []
    for answer in (3.1, None):
        for _ in range(500):
            p = gate.pending
            if p is not None:
                break
            threading.Event().wait(0.01)
        assert p is not None, "engine never asked for the torque"
        seen.append(p)
        assert gen.s.output is False and engine.state == "waiting"
        n_runs = len([d for n, d in col.docs if n == "stop"])
        gate.confirm(answer)
        assert n_runs == len(seen) - 1  # nothing was recorded while waiting
    t.join(5)
    assert [p["torque_nm"] for p in seen] == [3.0, 5.0] and all(p["kind"] == "torque" for p in seen)
    assert out["r"].status == "complete"
    starts = [d for n, d in col.docs if n == "start"]
    assert [s.metadata["torque_nm"] for s in starts] == [3.1, 5.0]
    assert starts[0].metadata["torque_requested_nm"] == 3.0
    assert starts[0].metadata["rig_backend"] == "sim"  # from the config; the gate is backend-agnostic


def test_operator_cancel_aborts_and_a_real_rig_without_gate_fails():
    gate = TorqueGate(poll_s=0.01)
    engine, gen, daq, col = make(sim=False, gate=gate)
    out = {}
    t = threading.Thread(target=lambda: out.update(r=engine.run(torque_series([3], n_cycles=10))))
    t.start()
    for _ in range(500):
        if gate.pending:
            break
        threading.Event().wait(0.01)
    gate.cancel("bolt stripped")
    t.join(5)
    assert out["r"].status == "aborted" and "bolt stripped" in out["r"].reason
    with pytest.raises(InputError):
        gate.confirm()  # nothing pending any more
    engine2, gen2, *_ = make(sim=False)
    r = engine2.run([SetTorque(5)])
    assert r.status == "failed" and "gate" in r.reason


def test_pause_restores_the_output_after_resume_and_is_skipped_on_the_sim():
    gate = TorqueGate(poll_s=0.01)
    engine, gen, daq, col = make(sim=False, gate=gate)
    out = {}
    plan = [Configure(400, 6), Output(True), Checkpoint("before"), Pause("check the sensor"),
            Record("after", n_cycles=10), Output(False)]
    t = threading.Thread(target=lambda: out.update(r=engine.run(plan)))
    t.start()
    for _ in range(500):
        if gate.pending:
            break
        threading.Event().wait(0.01)
    assert gate.pending == {"kind": "pause", "reason": "check the sensor"} and gen.s.output is False
    gate.resume()
    t.join(5)
    start = col.docs[0][1]
    assert out["r"].status == "complete" and start.metadata["excitation_vpp"] == 6.0
    assert start.metadata["checkpoint"] == {"label": "before"}
    engine2, gen2, daq2, col2 = make(sim=True)
    assert engine2.run(plan).status == "complete"
