"""Effects injected into the simulated joint show their signatures; families follow their laws."""

import math

import numpy as np
import pytest

from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings
from labjoint.hardware.sim import SimConfig, SimRig
from labjoint.hardware.sim.contact import make_rings
from labjoint.hardware.sim.effects import parse_joint
from labjoint.hardware.sim.joint import prescribed_displacement, ra_backbone

FS = 50000.0
QUIET = {"sensors": {"force_noise_n": 0.0, "displacement_noise_m": 0.0, "nanocomposite_noise_n": 0.0,
                     "voltage_noise_v": 0.0, "daq_noise_v": 0.0}}
CHANNELS = [
    ChannelSpec("force_ref", "force", "force", "N", 50.0),
    ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5),
    ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5),
    ChannelSpec("shear_nc", "nanocomposite", "force", "N", 301.0),
]
K = 12e6


def run(f=400.0, vpp=10.0, joint="none", effects=(), settle_s=0.25, cycles=20):
    """Steady cycles; returns (u, F_joint, u_measured, F_sensed, rig) noise-free."""
    rig = SimRig(SimConfig.from_dict({**QUIET, "joint": joint, "effects": list(effects)}), CHANNELS, FS)
    s = GeneratorSettings(f, vpp, 0.0, True)
    rig.advance(int(settle_s * FS), s)
    rig.advance(int(round(cycles * FS / f)) + 1, s)  # closed loops: whole periods plus the end point
    ts = rig.true_state()
    um = ts.sensed["disp_1"] - ts.sensed["disp_2"]
    return ts.u, ts.joint_force, um, ts.sensed["shear_nc"], rig


def area(u, F, cycles=20):
    return np.sum(0.5 * (F[1:] + F[:-1]) * np.diff(u)) / cycles


def amp(x):
    return 0.5 * (x.max() - x.min())


LINEAR = {"name": "linear_stiffness", "k": K}


@pytest.mark.parametrize("f", [200.0, 400.0])
def test_viscous_adds_loss_proportional_to_frequency(f):
    c = 300.0
    u, F, *_ = run(f, effects=[LINEAR, {"name": "viscous", "c": c}])
    assert area(u, F) == pytest.approx(math.pi * c * 2 * math.pi * f * amp(u) ** 2, rel=0.01)


def test_cubic_stiffness_raises_stiffness_with_amplitude():
    k3 = 2e17
    sec = []
    for vpp in (4.0, 16.0):
        u, F, *_ = run(vpp=vpp, effects=[LINEAR, {"name": "cubic_stiffness", "k3": k3}])
        U = np.max(u)
        assert F[np.argmax(u)] / U == pytest.approx(K + k3 * U**2, rel=1e-6)
        sec.append(amp(F) / amp(u))
    assert sec[1] > sec[0] * 1.05


@pytest.mark.parametrize("f", [200.0, 400.0])
def test_inertia_lowers_apparent_stiffness_by_m_omega_squared(f):
    m = 0.1
    u, F, um, Fs, _ = run(f, effects=[LINEAR, {"name": "inertia", "m": m}])
    np.testing.assert_allclose(F, K * u, rtol=1e-12)  # the joint itself is unchanged
    slope = np.polyfit(um, Fs, 1)[0]
    assert slope == pytest.approx(K - m * (2 * math.pi * f) ** 2, rel=2e-3)


def test_offset_is_a_held_preload_visible_in_the_joint_force_only():
    u0, F0_, _, Fs0, _ = run(joint="contact")
    u1, F1, _, Fs1, _ = run(joint="contact", effects=[{"name": "offset", "F0": 25.0}])
    np.testing.assert_array_equal(u1, u0)  # motion unchanged: the supports hold the reaction
    np.testing.assert_allclose(F1 - F0_, 25.0, atol=1e-9)
    assert np.mean(Fs1) - np.mean(Fs0) == pytest.approx(25.0, rel=1e-9)


@pytest.mark.parametrize("tau", [6e-6, 2e-5, -6e-6])
def test_channel_delay_changes_loop_area_by_pi_f_u_sin_omega_tau(tau):
    u, F, um, Fs, _ = run(effects=[LINEAR, {"name": "channel_delay", "tau": tau}])
    w = 2 * math.pi * 400.0
    expected = -math.pi * amp(Fs) * amp(um) * math.sin(w * tau)
    assert abs(area(u, F)) < 1e-4 * abs(expected)  # the joint is lossless, the measured loop is not
    assert area(um, Fs) == pytest.approx(expected, rel=0.01)
    ph = np.angle(np.sum(Fs * np.exp(-1j * w * np.arange(len(Fs)) / FS)) /
                  np.sum(um * np.exp(-1j * w * np.arange(len(um)) / FS)))
    assert -ph == pytest.approx(w * tau, abs=0.01 * w / FS)  # << 1 sample


def test_wear_makes_the_loss_drift_over_cycles():
    e_w = 0.5
    rig = SimRig(SimConfig.from_dict({**QUIET, "joint": "dry_microslip",
                                      "effects": [{"name": "wear", "E_w": e_w}]}), CHANNELS, FS)
    s = GeneratorSettings(400.0, 20.0, 0.0, True)
    rig.advance(10000, s)
    losses = []
    for _ in range(6):
        rig.advance(5000, s)
        ts = rig.true_state()
        losses.append(area(ts.u[-1251:], ts.joint_force[-1251:], 10))
    d = np.diff(losses)
    assert np.all(d > 0) or np.all(d < 0)
    assert losses[-1] / losses[0] - 1 > 0.05  # weaker sliders slip more at this drive
    assert rig.wear_factor == pytest.approx(math.exp(-rig.dissipated_energy_j / e_w))
    assert rig.wear_factor < 0.95
    u, F, *_ = run(joint="contact", vpp=20.0, settle_s=0.2, cycles=40)
    steady = [area(u[i * 250:(i + 1) * 250 + 1], F[i * 250:(i + 1) * 250 + 1], 2) for i in range(20)]
    assert np.ptp(steady) < 1e-3 * np.mean(steady)  # without wear the loss does not drift


def _jenkins_reference(u, k, f, asym):
    """Plain-Python parallel Jenkins elements with direction-dependent slip strengths."""
    z = np.zeros_like(k)
    out = np.empty_like(u)
    for i, x in enumerate(u):
        z = np.clip(z, x - f * (1 + asym) / k, x + f * (1 - asym) / k)
        out[i] = np.sum(k * (x - z))
    return out


def test_asymmetric_slip_shifts_the_loop_by_the_slip_strength_difference():
    rings = make_rings(normal_force_n=2390.0, bolt_radius_m=5e-3, friction_coefficient=0.168,
                       shear_stiffness_n_per_m=14e6)
    t = np.arange(4000) / 1000.0
    u = 8e-6 * np.sin(2 * np.pi * t)
    sym = prescribed_displacement(parse_joint("contact", []), u, rings=rings)
    asy = prescribed_displacement(parse_joint("contact", [{"name": "asymmetric_slip", "asym": 0.3}]), u, rings=rings)
    np.testing.assert_allclose(asy, _jenkins_reference(u, rings.stiffness, rings.slip_force, 0.3), atol=1e-9)
    last = slice(-1000, None)
    # rings slipping both ways shift by asym f; rings slipping once (phi (1 - asym) < U < phi) by less
    phi, f = rings.slip_displacement, rings.slip_force
    shift = np.mean(asy[last]) - np.mean(sym[last])
    assert 0.3 * f[phi < 8e-6].sum() < shift < 0.3 * f[phi * 0.7 < 8e-6].sum()
    assert amp(asy[last]) == pytest.approx(amp(sym[last]), rel=1e-9)  # same loop, shifted
    assert abs(np.mean(sym[last])) < 1e-6 * amp(sym[last])


def test_backlash_gives_zero_force_inside_the_gap():
    gap = 4e-6
    u, F, *_ = run(effects=[LINEAR, {"name": "backlash", "gap": gap}])
    inside = np.abs(u) < gap / 2
    assert inside.mean() > 0.2
    assert np.all(F[inside] == 0.0)
    np.testing.assert_allclose(F[~inside], K * (u - np.sign(u) * gap / 2)[~inside], rtol=1e-12)
    # with the contact the force is frozen inside the gap (the rings see no motion)
    u, F, *_ = run(joint="contact", effects=[{"name": "backlash", "gap": gap}])
    inside = np.flatnonzero(np.abs(u) < gap / 2 * 0.99)
    runs = np.split(inside, np.flatnonzero(np.diff(inside) > 1) + 1)
    assert all(np.ptp(F[r]) < 1e-9 for r in runs if len(r) > 1)


def test_coulomb_joint_dissipates_4_fs_u_minus_fs_over_k():
    k, fs = 12e6, 40.0
    u, F, *_ = run(vpp=20.0, joint={"family": "coulomb", "k": k, "f_s": fs})
    U = amp(u)
    assert U > fs / k
    assert area(u, F) == pytest.approx(4 * fs * (U - fs / k), rel=2e-3)
    assert np.max(np.abs(F)) == pytest.approx(fs, rel=1e-9)


def test_iwan_family_matches_segalman_dissipation():
    FS_, KT, chi, beta = 100.0, 1e7, -0.5, 0.5
    spec = parse_joint({"family": "iwan", "F_S": FS_, "K_T": KT, "chi": chi, "beta": beta}, [])
    c = (chi + 1) / (chi + 2)
    phi_max = FS_ * (1 + beta) / (KT * (beta + c))
    R = FS_ * (chi + 1) / (phi_max ** (chi + 2) * (beta + c))
    t = np.arange(6000) / 2000.0
    for frac in (0.02, 0.3, 0.9):
        U = frac * phi_max
        u = U * np.sin(2 * np.pi * t)
        F = prescribed_displacement(spec, u)
        w = area(u[-2001:], F[-2001:], 1)
        assert w == pytest.approx(4 * R * U ** (chi + 3) / ((chi + 2) * (chi + 3)), rel=5e-3)
    F = prescribed_displacement(spec, 3 * phi_max * np.sin(2 * np.pi * t))
    assert np.max(F) == pytest.approx(FS_, rel=1e-9)  # macro-slip force
    tiny = 1e-6 * phi_max  # below every slip threshold: the initial stiffness K_T
    assert prescribed_displacement(spec, np.array([0.0, tiny]))[1] / tiny == pytest.approx(KT, rel=1e-9)


def test_bouc_wen_saturates_with_initial_stiffness_k0():
    spec = parse_joint({"family": "bouc_wen", "k0": 1e7, "alpha": 2000.0, "beta": 2000.0, "n": 2.0}, [])
    u = np.linspace(0, 1e-4, 20001)
    F = prescribed_displacement(spec, u)
    # monotonic loading: dz/du = k0 - (alpha + beta) z^2 = k0 (1 - (z/F)^2), F = (k0 / 4000)^(1/2) = 50
    # ->  z = F tanh(k0 u / F)
    np.testing.assert_allclose(F, 50.0 * np.tanh(1e7 * u / 50.0), atol=1e-6)


def test_richard_abbott_follows_backbone_then_masing_branch():
    ke, kp, fy, n = 1e7, 2e5, 50.0, 2.0
    spec = parse_joint({"family": "richard_abbott", "ke": ke, "kp": kp, "F_y": fy, "n": n}, [])
    up = np.linspace(0, 2e-5, 2001)
    u = np.concatenate([up, up[::-1][1:] - 0.0])
    F = prescribed_displacement(spec, u)
    g = np.array([ra_backbone(x, ke, kp, fy, n) for x in up])
    np.testing.assert_allclose(F[:2001], g, rtol=1e-12)
    ur, fr = up[-1], g[-1]
    down = up[::-1][1:]
    masing = fr + 2 * np.array([ra_backbone(0.5 * (x - ur), ke, kp, fy, n) for x in down])
    np.testing.assert_allclose(F[2001:], masing, rtol=1e-9, atol=1e-9)


def test_valanis_tangent_tends_to_et_in_slip():
    E0, Et, lam, kappa = 1e7, 2e5, 2e5, 0.5
    spec = parse_joint({"family": "valanis", "E0": E0, "Et": Et, "lam": lam, "kappa": kappa}, [])
    u = np.linspace(0, 2e-4, 20001)
    F = prescribed_displacement(spec, u)
    assert (F[1] - F[0]) / (u[1] - u[0]) == pytest.approx(E0, rel=1e-3)
    assert (F[-1] - F[-2]) / (u[-1] - u[-2]) == pytest.approx(Et, rel=1e-3)


def test_hysteretic_effect_adds_in_parallel_with_the_contact():
    u0, F0_, *_ = run(joint="contact", vpp=20.0)
    u1, F1, *_ = run(joint="contact", vpp=20.0, effects=[{"name": "coulomb", "k": 5e6, "f_s": 10.0}])
    assert amp(F1) / amp(u1) > amp(F0_) / amp(u0)          # stiffer
    assert area(u1, F1) > area(u0, F0_) * (amp(u1) / amp(u0)) ** 3  # and lossier than amplitude explains
