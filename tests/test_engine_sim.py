"""RunEngine end to end on the physics-based simulated rig (AFG1022 driver on pyvisa-sim,
SimDAQ), writing real run files; fake clock/sleep, short runs at 25 kS/s."""

import math
import threading

import numpy as np
import pytest

from labjoint.acquisition.engine import FLOOR_VPP, RunEngine
from labjoint.acquisition.frf import stepped_frf
from labjoint.acquisition.gate import TorqueGate
from labjoint.acquisition.messages import Configure, Output, Record
from labjoint.acquisition.online import fundamental
from labjoint.acquisition.plans import (amplitude_sweep, broadband, friction_test, sensor_calibration,
                                        step_sine, torque_series)
from labjoint.acquisition.rig import open_rig
from labjoint.config import load_config

pytest.importorskip("labjoint.hardware.sim.devices")
storage = pytest.importorskip("labjoint.storage")

FS = 25000.0
QUICK = dict(steady_max_cycles=200, steady_tol=0.02, steady_window=8)


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.t += dt


class Recorder:
    """Delegates to the real generator; logs every applied amplitude with the clock."""

    def __init__(self, gen, clock):
        self.gen, self.clock, self.history = gen, clock, []

    def __getattr__(self, name):
        return getattr(self.gen, name)

    def apply(self, f, vpp, offset=0.0):
        rb = self.gen.apply(f, vpp, offset)
        self.history.append((self.clock(), rb.amplitude_vpp))
        return rb

    def set_amplitude(self, vpp):
        rb = self.gen.set_amplitude(vpp)
        self.history.append((self.clock(), rb.amplitude_vpp))
        return rb


def config(**limits):
    over = {"daq": {"sample_rate_hz": FS, "block_samples": 1250}}
    if limits:
        over["limits"] = limits
    return load_config(overrides=over)


@pytest.fixture
def sim():
    """(rig, engine factory): the factory makes an engine on the rig with a fake clock."""
    rigs = []

    def factory(callbacks=(), cfg=None, **kw):
        rig = open_rig(cfg or config())
        rigs.append(rig)
        clock = Clock()
        gen = Recorder(rig.generator, clock)
        engine = RunEngine(gen, rig.daq, rig.config.limits, list(callbacks), clock=clock,
                           sleep=clock.sleep, rig=kw.pop("rig", rig.sim), config=rig.config, **kw)
        return rig, engine, gen

    yield factory
    for r in rigs:
        r.close()


def open_blocks(docs):
    """Blocks emitted into the run that is open now (-1 if none is open)."""
    n = -1
    for name, _ in docs:
        n = 0 if name == "start" else -1 if name == "stop" else n + (name == "block" and n >= 0)
    return n


def by_run(docs):
    runs = []
    for name, doc in docs:
        if name == "start":
            runs.append({"start": doc, "blocks": [], "markers": []})
        elif name == "block":
            runs[-1]["blocks"].append(doc)
        elif name == "marker":
            runs[-1]["markers"].append(doc)
        elif name == "stop":
            runs[-1]["stop"] = doc
    for r in runs:
        r["volts"] = np.concatenate([b.volts for b in r["blocks"]], axis=1) if r["blocks"] else None
    return runs


def amp(run, channel, rig):
    f = run["start"].metadata["frequency_hz"]
    names = [c.name for c in rig.daq.channels]
    i = names.index(channel)
    return abs(fundamental(run["volts"][i:i + 1], FS, f)[0]) * rig.daq.channels[i].units_per_volt(f)


def rel_disp_amp(run, rig):
    f = run["start"].metadata["frequency_hz"]
    s = [c.units_per_volt(f) for c in rig.daq.channels]
    u = run["volts"][1] * s[1] - run["volts"][2] * s[2]
    return abs(fundamental(u, FS, f)[0])


def test_generator_is_the_afg1022_driver_on_pyvisa_sim(sim):
    rig, engine, gen = sim()
    assert type(rig.generator).__name__ == "AFG1022" and rig.sim is not None
    assert rig.generator.read_settings().output is False
    assert rig.daq.sample_rate_hz == FS


def test_amplitude_sweep_of_three_runs_to_run_files(sim, tmp_path):
    docs = []
    writer = storage.RunWriter(tmp_path)
    rig, engine, gen = sim([writer, lambda n, d: docs.append((n, d))])
    r = engine.run(amplitude_sweep([4, 12, 20], frequency_hz=400, torque_nm=5, n_cycles=30, **QUICK))
    assert r.status == "complete" and [x.status for x in r.runs] == ["complete"] * 3
    runs = by_run(docs)
    n = math.ceil(30 * FS / 400)
    for run, vpp, x in zip(runs, (4.0, 12.0, 20.0), r.runs):
        md = run["start"].metadata
        assert md["excitation_vpp"] == vpp and md["generator"]["amplitude_vpp"] == vpp
        assert md["frequency_hz"] == 400.0 and md["torque_nm"] == 5.0 and md["normal_force_n"] == 2390.0
        assert md["rig_backend"] == "sim" and md["steady"]["reached"]
        firsts = [b.first_sample for b in run["blocks"]]
        assert firsts == [0, 1250] and run["stop"].n_samples == n == run["volts"].shape[1] == 1875
        with storage.open_run(tmp_path / f"{x.name}.h5") as f:
            assert f.status == "complete" and f.n_samples == n and f.gaps == []
            assert f.metadata["plan"] == "amplitude_sweep" and f.metadata["excitation_vpp"] == vpp
            assert [m["name"] for m in f.metadata["markers"]] == ["steady"]
    u = [rel_disp_amp(run, rig) for run in runs]
    fref = [amp(run, "force_ref", rig) for run in runs]
    assert u[0] < u[1] < u[2]  # more excitation, more relative motion
    assert np.allclose(np.array(fref) / [4, 12, 20], fref[2] / 20, rtol=0.05)  # drive force ~ Vpp
    assert rig.generator.read_settings().output is False


def test_ramps_are_rate_limited_on_the_instrument(sim):
    rig, engine, gen = sim()
    r = engine.run(amplitude_sweep([2, 20], n_cycles=10, **QUICK))
    assert r.status == "complete"
    rate = rig.config.limits.ramp_vpp_per_s
    h = gen.history
    assert max(v for _, v in h) == 20.0 and h[-1][1] == FLOOR_VPP
    for (t0, v0), (t1, v1) in zip(h, h[1:]):
        assert abs(v1 - v0) <= rate * (t1 - t0) * (1 + 1e-3) + 1e-4


def test_limit_trips_while_ramping_up_and_the_amplitude_goes_back_down(sim):
    rig, engine, gen = sim(cfg=config(max_displacement_m=5e-6))
    # at 400 Hz, 5 Nm the relative displacement is ~7 um at 20 Vpp (sim defaults), so the
    # 5 um limit is crossed on the way up, while the DAQ is read during the ramp
    r = engine.run([Configure(400, 20), Output(True), Record("never", n_cycles=100)])
    assert r.status == "limit" and r.runs == []
    assert "max_displacement_m" in r.reason and "disp_1-disp_2" in r.reason
    vpps = [v for _, v in gen.history]
    top = max(vpps)
    assert 10.0 < top < 20.0  # stopped part-way up
    down = vpps[vpps.index(top):]
    assert len(down) > 3 and down == sorted(down, reverse=True) and down[-1] == FLOOR_VPP
    assert rig.generator.read_settings().output is False


def test_limit_inside_a_record_is_stored_in_the_run_file(sim, tmp_path):
    def tighten(name, doc):  # the steady response crosses a (tightened) limit mid-record
        if name == "start":
            engine.limits = config(max_displacement_m=5e-6).limits

    rig, engine, gen = sim([storage.RunWriter(tmp_path), tighten])
    r = engine.run([Configure(400, 20), Output(True), Record("too_far", n_cycles=100)], name_prefix="")
    assert r.status == "limit" and [x.status for x in r.runs] == ["limit"]
    with storage.open_run(tmp_path / "too_far.h5") as f:
        assert f.status == "limit" and "max_displacement_m" in f.metadata["reason"]
        assert f.n_samples == 1250  # the block that tripped is kept
        (marker,) = [m for m in f.metadata["markers"] if m["name"] == "limit"]
        assert marker["data"]["value"] > 5e-6 and marker["sample"] < 1250
    assert rig.generator.read_settings().output is False


def test_overrun_fails_the_run_and_keeps_its_data(sim, tmp_path):
    def arm(name, doc):  # the read reaching 3000 samples into the run overruns
        if name == "start":
            rig.daq.inject_overrun(at_sample=rig.daq.samples_read + 3000)

    rig, engine, gen = sim([storage.RunWriter(tmp_path), arm])
    r = engine.run([Configure(400, 10), Output(True), Record("r", n_cycles=100)], name_prefix="")
    assert r.status == "failed" and "BufferOverrun" in r.reason
    with storage.open_run(tmp_path / "r.h5") as f:
        assert f.status == "failed" and f.n_samples == 2500 and f.gaps == []
        assert "BufferOverrun" in f.metadata["reason"]
        assert np.abs(f.volts("disp_1")).max() > 0
    assert rig.generator.read_settings().output is False


def test_generator_timeout_mid_run_fails_and_output_off_is_attempted(sim, monkeypatch):
    import pyvisa

    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    res = rig.generator._res
    real_query, real_write = res.query, res.write
    armed, writes = {"on": False}, []

    def query(cmd, *a, **k):
        if armed["on"]:
            raise pyvisa.errors.VisaIOError(pyvisa.constants.StatusCode.error_timeout)
        return real_query(cmd, *a, **k)

    def write(cmd, *a, **k):
        writes.append(cmd)
        return real_write(cmd, *a, **k)

    monkeypatch.setattr(res, "query", query)
    monkeypatch.setattr(res, "write", write)
    real_read = rig.daq.read

    def read(n, out=None):
        if open_blocks(docs) == 2:
            armed["on"] = True  # the instrument stops answering mid-record
        return real_read(n, out)

    monkeypatch.setattr(rig.daq, "read", read)
    r = engine.run([Configure(400, 10), Output(True), Record("r", n_cycles=100)])
    assert r.status == "failed" and "InstrumentTimeout" in r.reason
    stop = docs[-1][1]
    assert stop.status == "failed" and stop.n_samples == 2500
    assert writes[-2:] == ["OUTPut1:STATe OFF", "OUTPut2:STATe OFF"]  # both, still tried
    armed["on"] = False
    assert rig.generator.read_settings().output is False


def test_exception_in_plan_code_leaves_the_output_off(sim):
    rig, engine, gen = sim()

    def plan():
        yield Configure(400, 8)
        yield Output(True)
        raise RuntimeError("plan bug")

    with pytest.raises(RuntimeError, match="plan bug"):
        engine.run(plan())
    assert rig.generator.read_settings().output is False


def test_emergency_stop_from_another_thread(sim, monkeypatch):
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    reading, release = threading.Event(), threading.Event()
    real_read = rig.daq.read

    def read(n, out=None):
        if open_blocks(docs) == 2:
            reading.set()
            assert release.wait(10)
        return real_read(n, out)

    monkeypatch.setattr(rig.daq, "read", read)
    out = {}
    t = threading.Thread(target=lambda: out.update(r=engine.run(
        [Configure(400, 16), Output(True), Record("r", n_cycles=1000)])))
    t.start()
    assert reading.wait(10)
    engine.emergency_stop("stop button")
    s = rig.generator.read_settings()
    assert s.output is False and s.amplitude_vpp == 16.0  # off at once, not ramped
    release.set()
    t.join(10)
    assert out["r"].status == "aborted" and docs[-1][1].status == "aborted"
    assert docs[-1][1].reason == "stop button"


def test_torque_series_on_the_sim_applies_each_torque(sim):
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    r = engine.run(torque_series([3, 5, 8], n_cycles=20, **QUICK))
    assert r.status == "complete" and rig.sim.torque_nm == 8.0
    runs = by_run(docs)
    assert [x["start"].metadata["normal_force_n"] for x in runs] == [1434.0, 2390.0, 3824.0]
    u = [rel_disp_amp(x, rig) for x in runs]
    assert u[0] > u[1] > u[2]  # a tighter bolt makes a stiffer joint (seed 002 Table 4)


def test_torque_series_on_a_real_style_rig_waits_for_the_operator(sim):
    gate = TorqueGate(poll_s=0.005)
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))], rig=None, torque_gate=gate)
    out = {}
    t = threading.Thread(target=lambda: out.update(r=engine.run(torque_series([3, 8], n_cycles=10, **QUICK))))
    t.start()
    asked = []
    while t.is_alive() or gate.pending:
        p = gate.pending
        if p is None:
            t.join(0.005)
            continue
        assert rig.generator.read_settings().output is False  # never excited while waiting
        asked.append(p["torque_nm"])
        gate.confirm()
    t.join(10)
    assert asked == [3.0, 8.0] and out["r"].status == "complete"
    assert rig.sim.torque_nm == 5.0  # the engine did not touch the rig: the operator does
    assert [d.metadata["torque_nm"] for n, d in docs if n == "start"] == [3.0, 8.0]


def test_step_sine_holds_the_reference_force_across_the_drive_resonance(sim):
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    r = engine.run(step_sine([200, 230, 260], 40.0, initial_vpp=2.0, n_cycles=20, measure_cycles=10,
                             **QUICK))
    assert r.status == "complete" and len(r.runs) == 6
    runs = by_run(docs)
    for run in runs:
        assert amp(run, "force_ref", rig) == pytest.approx(40.0, rel=0.03)
        assert run["start"].metadata["force_converged"] is True
    vpp = {(x["start"].metadata["direction"], x["start"].metadata["frequency_hz"]):
           x["start"].metadata["excitation_vpp"] for x in runs}
    # the armature-link resonance sqrt(k_link / m_armature) / 2 pi ~ 232 Hz needs the least drive
    for d in ("up", "down"):
        assert vpp[(d, 230.0)] < min(vpp[(d, 200.0)], vpp[(d, 260.0)])


def test_broadband_h1_matches_the_two_beam_closed_form(sim):
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    r = engine.run(broadband(f_start_hz=100, f_stop_hz=600, n_frequencies=6, amplitude_vpp=0.5,
                             n_cycles=30, **QUICK))
    assert r.status == "complete"
    records = []
    for run in by_run(docs):
        f = run["start"].metadata["frequency_hz"]
        s = [c.units_per_volt(f) for c in rig.daq.channels]
        v = run["volts"]
        records.append((f, v[0] * s[0], v[1] * s[1] - v[2] * s[2], FS))
    freqs, h1, coh = stepped_frf(records)
    # beams m1 = m2 = m on supports k_s, joint complex stiffness K(w) (stick: the rings
    # K_c in series with the shear layer k_l + i w c_l), driven by +-F:
    # m u'' = 2F - (2K + k_s) u  ->  1/H1 = K(w) + k_s/2 - (m/2) w^2
    cfg = rig.sim.config
    dyn = cfg.dynamics
    m = dyn.beam_masses_kg[0]
    w = 2 * np.pi * freqs
    k_l, c_l = cfg.layer
    joint = 1 / (1 / (k_l + 1j * w * c_l) + 1 / cfg.ring_stiffness_n_per_m)
    expected = joint + dyn.support_stiffness_n_per_m / 2 - m / 2 * w ** 2
    assert np.allclose(1 / np.abs(h1), np.abs(expected), rtol=0.03)
    assert np.all(coh > 0.99)


def test_friction_test_defaults_reach_macro_slip(sim):
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    assert engine.run(friction_test(n_cycles=20, **QUICK)).status == "complete"
    run = by_run(docs)[0]
    md = run["start"].metadata
    f = md["frequency_hz"]
    i = [c.name for c in rig.daq.channels].index(md["joint_force_channel"])
    peak = np.abs(run["volts"][i] * rig.daq.channels[i].units_per_volt(f)).max()
    slip_limit = rig.sim.config.contact.friction_coefficient * md["normal_force_n"]  # seed 002 Eq. 10
    assert (f, md["torque_nm"]) == (100.0, 2.0)
    assert peak == pytest.approx(slip_limit, rel=0.05)  # the joint force saturates at mu N


def test_sensor_calibration_runs_are_tagged(sim):
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    r = engine.run(sensor_calibration([300, 400], n_cycles=10, **QUICK))
    assert r.status == "complete"
    starts = [d for n, d in docs if n == "start"]
    assert [(s.metadata["plan"], s.metadata["frequency_hz"]) for s in starts] == [
        ("sensor_calibration", 300.0), ("sensor_calibration", 400.0)]
    assert all(s.metadata["joint_force_channel"] == "shear_nc"
               and s.metadata["reference_force_channel"] == "force_ref" for s in starts)



def test_sensor_calibration_keeps_every_channel_in_range_at_every_default_frequency(sim):
    # Before: 20 Vpp at 200 Hz drove the reference force channel into its +-5 V range.
    docs = []
    rig, engine, gen = sim([lambda n, d: docs.append((n, d))])
    r = engine.run(sensor_calibration(n_cycles=10, measure_cycles=5, **QUICK))
    assert r.status == "complete"
    runs = by_run(docs)
    assert len(runs) == 5
    ranges = np.array([c.range_v for c in rig.daq.channels])
    for run in runs:
        peak = np.abs(run["volts"]).max(axis=1) / ranges
        assert peak.max() < 0.9, (run["start"].metadata["frequency_hz"], peak)
    md = [run["start"].metadata for run in runs]
    assert any(m["range_limited_by"] for m in md)          # some frequency needed less drive
    assert all(m["requested_vpp"] == 20.0 for m in md)
