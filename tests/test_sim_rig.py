"""Simulated rig: dynamics from rest to steady state, seed 002 operating points, torque, streaming."""

import numpy as np
import pytest

from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings
from labjoint.hardware.sim import SimConfig, SimRig

FS = 50000.0
MU = 0.168
QUIET = {"sensors": {"force_noise_n": 0.0, "displacement_noise_m": 0.0, "nanocomposite_noise_n": 0.0,
                     "voltage_noise_v": 0.0, "daq_noise_v": 0.0}}
CHANNELS = [
    ChannelSpec("force_ref", "force", "force", "N", 50.0),
    ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5),
    ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5),
    ChannelSpec("shear_nc", "nanocomposite", "force", "N", 301.0),
]


def make_rig(torque=5.0, quiet=True, fs=FS, **sim):
    data = dict(QUIET) if quiet else {}
    data.update(sim)
    data.setdefault("contact", {})
    data["contact"] = {**data["contact"], "torque_nm": torque}
    return SimRig(SimConfig.from_dict(data), CHANNELS, fs)


def steady_loop(rig, f, vpp, settle_s=0.2, cycles=20):
    """Run ``settle_s`` then ``cycles`` whole periods; return (true state, energy/cycle, secant, U, F)."""
    s = GeneratorSettings(f, vpp, 0.0, True)
    rig.advance(int(settle_s * rig.sample_rate_hz), s)
    rig.advance(int(round(cycles * rig.sample_rate_hz / f)) + 1, s)  # whole periods plus the end point
    ts = rig.true_state()
    u, F = ts.u, ts.joint_force
    w = np.sum(0.5 * (F[1:] + F[:-1]) * np.diff(u)) / cycles
    U = 0.5 * (u.max() - u.min())
    Fa = 0.5 * (F.max() - F.min())
    return ts, w, Fa / U, U, Fa


def cycle_amplitudes(u, period):
    n = len(u) // period
    c = u[: n * period].reshape(n, period)
    return 0.5 * (c.max(axis=1) - c.min(axis=1))


def test_reference_condition_is_micro_slip_like_seed_002_table_2():
    rig = make_rig(5.0)
    _, w, k, U, Fa = steady_loop(rig, 400.0, 20.0)
    assert 5e-6 < U < 10e-6
    assert 60.0 < Fa < 120.0
    assert 10e6 < k < 13e6  # Table 2: 11.8 MN/m
    assert Fa < 0.5 * MU * rig.normal_force_n and w > 0
    rs = rig.ring_state()
    slipped = rs["slider"] != 0.0
    first = np.argmax(slipped)
    assert 0 < first < len(slipped) - 1 and slipped[first:].all() and not slipped[:first].any()


def test_starts_from_rest_and_reaches_steady_state_within_0_2_s():
    rig = make_rig()
    s = GeneratorSettings(400.0, 20.0, 0.0, True)
    rig.advance(20000, s)
    ts = rig.true_state()
    assert abs(ts.u[0]) < 1e-9  # starts from rest
    amps = cycle_amplitudes(ts.u, 125)
    assert abs(amps[2] / amps[-1] - 1) > 0.02  # a start-up transient exists
    late = amps[-40:]  # 0.3 s .. 0.4 s
    assert np.ptp(late) / late.mean() < 1e-3
    settled = amps[int(0.2 * 400):]
    assert np.ptp(settled) / settled.mean() < 3e-3


def test_beams_move_in_antiphase():
    ts, *_ = steady_loop(make_rig(), 400.0, 10.0)
    assert np.corrcoef(ts.x1, ts.x2)[0, 1] < -0.9999
    assert np.ptp(ts.x1) == pytest.approx(np.ptp(ts.x2), rel=1e-6)
    # the joint resists the relative displacement: a sticking joint has F ~ K u with K > 0
    assert np.polyfit(ts.u, ts.joint_force, 1)[0] > 0


def test_amplitude_sweep_loss_rises_faster_than_square_and_stiffness_softens():
    """The dry contact alone (the wave-1 joint): dissipation by micro-slip only."""
    res = [steady_loop(make_rig(joint="dry_microslip"), 400.0, v)[1:4]
           for v in (1.0, 4.0, 8.0, 12.0, 16.0, 20.0)]
    w, k, U = (np.array(x) for x in zip(*res))
    assert np.all(np.diff(w) > 0)
    assert np.all(np.diff(w / U**2) > 0)  # faster than amplitude^2 (micro-slip)
    assert np.all(np.diff(k) < 0)          # secant stiffness falls


def test_friction_test_100_hz_2_nm_reaches_macro_slip_at_mu_n():
    rig = make_rig(2.0)
    ts, w, k, U, Fa = steady_loop(rig, 100.0, 20.0, settle_s=0.3, cycles=10)
    n = rig.normal_force_n
    assert n == pytest.approx(956.0)
    assert np.max(np.abs(ts.joint_force)) / n == pytest.approx(MU, rel=1e-3)
    assert np.mean(np.abs(ts.joint_force) > 0.995 * MU * n) > 0.2  # sliding plateau
    assert np.all(rig.ring_state()["slider"] != 0)
    assert U < 60e-6  # displacement sensors (+-62.5 um) do not clip


def test_set_torque_changes_thresholds_keeps_state_and_lower_torque_softens():
    rig = make_rig(5.0)
    _, _, k5, _, _ = steady_loop(rig, 400.0, 20.0)
    f5 = rig.rings.slip_force.copy()
    z = rig.ring_state()["slider"].copy()
    u_last = rig.true_state().u[-1]
    rig.set_torque(3.0)
    assert rig.normal_force_n == pytest.approx(3 * 478.0)
    np.testing.assert_allclose(rig.rings.slip_force, f5 * 0.6)
    np.testing.assert_array_equal(rig.ring_state()["slider"], z)
    rig.advance(1, GeneratorSettings(400.0, 20.0, 0.0, True))
    assert abs(rig.true_state().u[0] - u_last) < 0.1 * 7e-6
    _, _, k3, _, _ = steady_loop(rig, 400.0, 20.0)
    assert k3 < k5  # seed 002 Table 4 trend: 11.8 -> 10.8 MN/m
    with pytest.raises(ConfigError):
        rig.set_torque(0.0)


def test_streaming_in_blocks_equals_one_block_and_seed_determines_noise():
    s = GeneratorSettings(400.0, 5.0, 0.0, True)
    a = make_rig(quiet=False)
    b = make_rig(quiet=False)
    one = a.advance(6000, s)
    two = np.hstack([b.advance(2500, s), b.advance(3500, s)])
    np.testing.assert_array_equal(one, two)
    c = make_rig(quiet=False, seed=1)
    other = c.advance(6000, s)
    assert not np.array_equal(one, other)
    np.testing.assert_array_equal(c.true_state().u, a.true_state().u)  # the seed draws noise only
    np.testing.assert_array_equal(a.true_state().u[-3500:], b.true_state().u)


def test_frequency_change_keeps_phase_continuity():
    rig = make_rig()
    rig.advance(1000, GeneratorSettings(400.0, 20.0, 0.0, True))
    v1 = rig.true_state().drive_v
    rig.advance(1000, GeneratorSettings(1000.0, 20.0, 0.0, True))
    v2 = rig.true_state().drive_v
    v = np.concatenate([v1, v2])
    max_step = 2 * np.pi * 1000.0 * 10.0 / FS
    assert np.max(np.abs(np.diff(v))) <= max_step * 1.001
    # after the change the drive is a 1 kHz sine
    spec = np.abs(np.fft.rfft(v2[-500:]))
    assert np.argmax(spec) == round(1000.0 * 500 / FS)


def test_output_off_gives_zero_drive_and_rings_down():
    rig = make_rig()
    _, _, _, U, _ = steady_loop(rig, 400.0, 20.0)
    rig.advance(10000, GeneratorSettings(400.0, 20.0, 0.0, False))
    ts = rig.true_state()
    assert np.all(ts.drive_v == 0)
    tail = ts.u[-1000:]
    assert np.ptp(tail) < 0.01 * 2 * U


def test_unknown_channel_and_wrong_quantity_are_config_errors():
    cfg = SimConfig.from_dict(QUIET)
    with pytest.raises(ConfigError) as exc:
        SimRig(cfg, [ChannelSpec("mystery", "force", "force", "N", 1.0)], FS)
    assert exc.value.field == "channels.mystery"
    with pytest.raises(ConfigError) as exc:
        SimRig(cfg, [ChannelSpec("disp_1", "capacitive", "force", "N", 1.0)], FS)
    assert exc.value.field == "channels.disp_1.quantity"
    roles = SimConfig.from_dict({**QUIET, "channel_roles": {"lc": "force_ref_2"}})
    rig = SimRig(roles, [ChannelSpec("lc", "force", "force", "N", 50.0)], FS)
    rig.advance(100, GeneratorSettings(400.0, 1.0, 0.0, True))


def test_reconfigure_draws_new_noise_and_reset_reproduces_the_run():
    s = GeneratorSettings(400.0, 5.0, 0.0, True)
    rig = make_rig(quiet=False)
    first = rig.advance(2000, s)
    rig.reset()
    assert rig.time_s == 0.0 and rig.dissipated_energy_j == 0.0
    np.testing.assert_array_equal(rig.advance(2000, s), first)
    rig.reset()
    rig.configure(CHANNELS, FS)  # same set-up, fresh noise streams
    again = rig.advance(2000, s)
    fresh = make_rig()
    fresh.advance(2000, s)
    np.testing.assert_array_equal(rig.true_state().u, fresh.true_state().u)  # same physics
    assert not np.array_equal(again, first)


def test_too_coarse_integration_step_is_refused():
    with pytest.raises(ConfigError) as exc:
        make_rig(effects=[{"name": "linear_stiffness", "k": 1e11}])
    assert exc.value.field == "sim.max_step_s"
    make_rig(effects=[{"name": "linear_stiffness", "k": 1e11}], max_step_s=1e-6)
