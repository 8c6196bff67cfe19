"""Contact pressure (seed 002 Eq. 2, Table 1), ring discretisation, and sim config validation."""

import math

import numpy as np
import pytest
from scipy import integrate

from labjoint.config import load_config
from labjoint.errors import ConfigError
from labjoint.hardware.sim import SimConfig
from labjoint.hardware.sim.contact import (
    TABLE1,
    bolt_stress,
    make_rings,
    normal_force,
    pressure,
    pressure_ratio,
    sliding_force,
)

RB = 5e-3
N = 478.0 * 5.0


def test_pressure_is_zero_at_the_contact_boundary_to_table_precision():
    assert abs(pressure_ratio(3.5)) < 1e-3 * TABLE1[0]
    assert pressure_ratio(0.0) == pytest.approx(TABLE1[0])
    x = np.linspace(0, 3.49, 200)
    p = pressure_ratio(x)
    assert np.all(p > 0) and np.all(np.diff(p) < 0)  # falls monotonically outwards


def test_integrated_pressure_equals_the_normal_force():
    a = 3.5 * RB
    total, _ = integrate.quad(lambda r: 2 * math.pi * r * float(pressure(r, N, RB)), 0.0, a, limit=200)
    assert total == pytest.approx(N, rel=1e-9)
    assert bolt_stress(2 * N, RB) == pytest.approx(2 * bolt_stress(N, RB))
    assert float(pressure(a * 1.01, N, RB)) == 0.0


def test_normal_force_from_torque_is_478_n_per_nm():
    assert normal_force(5.0) == pytest.approx(2390.0)
    assert normal_force(2.0) == pytest.approx(956.0)  # seed 002 Eq. 10: 956.3 N


def test_rings_sum_to_macro_slip_force_and_sticking_stiffness():
    rings = make_rings(normal_force_n=N, bolt_radius_m=RB, friction_coefficient=0.168,
                       shear_stiffness_n_per_m=14e6, n_rings=60)
    assert rings.slip_force.sum() == pytest.approx(0.168 * N, rel=1e-6)
    assert rings.stiffness.sum() == pytest.approx(14e6, rel=1e-12)
    assert rings.area.sum() == pytest.approx(math.pi * (3.5 * RB) ** 2, rel=1e-3)
    assert rings.r_out[-1] == pytest.approx(3.5 * RB, rel=2e-4)
    assert sliding_force(0.0, 0.168, N, RB) == pytest.approx(0.168 * N)


def test_outer_rings_slip_first():
    rings = make_rings(normal_force_n=N, bolt_radius_m=RB, friction_coefficient=0.168,
                       shear_stiffness_n_per_m=14e6)
    phi = rings.slip_displacement
    assert np.all(np.diff(phi) < 0)
    # at a micro-slip amplitude only an outer annulus slips, and more with more amplitude
    slipping = [rings.slip_displacement < u for u in (1e-6, 5e-6, 2e-5)]
    for s in slipping:
        k = np.argmax(s)
        assert not s[:k].any() and s[k:].all()
    assert slipping[0].sum() < slipping[1].sum() < slipping[2].sum() < len(phi)


def test_micro_slip_loss_grows_faster_than_amplitude_squared():
    rings = make_rings(normal_force_n=N, bolt_radius_m=RB, friction_coefficient=0.168,
                       shear_stiffness_n_per_m=14e6)
    u = np.array([0.5e-6, 2e-6, 8e-6])
    w = np.array([rings.dissipation(x) for x in u])
    assert np.all(np.diff(np.log(w)) / np.diff(np.log(u)) > 2.5)
    assert rings.backbone(2e-4) == pytest.approx(0.168 * N)


@pytest.mark.parametrize("kwargs, field", [
    (dict(bolt_radius_m=0.0), "contact.bolt_radius_m"),
    (dict(contact_ratio=1.0), "contact.contact_ratio"),
    (dict(friction_coefficient=-0.1), "contact.friction_coefficient"),
    (dict(normal_force_n=0.0), "normal_force_n"),
    (dict(n_rings=1), "contact.rings"),
])
def test_bad_contact_values_name_the_field(kwargs, field):
    args = dict(normal_force_n=N, bolt_radius_m=RB, friction_coefficient=0.168, shear_stiffness_n_per_m=14e6)
    args.update(kwargs)
    with pytest.raises(ConfigError) as exc:
        make_rings(**args)
    assert exc.value.field == field


def test_default_sim_config_from_the_rig_config():
    rc = load_config()
    cfg = SimConfig.from_rig(rc)
    assert cfg.seed == 0 and cfg.joint_spec.family == "contact"
    assert cfg.normal_force_n == pytest.approx(2390.0)
    assert cfg.channel_roles["shear_nc"] == "joint_force"
    assert cfg.module_spec.name == "NI 9233"


@pytest.mark.parametrize("sim, field", [
    ({"contact": {"friction_coefficient": 0}}, "sim.contact.friction_coefficient"),
    ({"contact": {"torque_nm": -5}}, "sim.contact.torque_nm"),
    ({"contact": {"contact_ratio": 0.9}}, "sim.contact.contact_ratio"),
    ({"dynamics": {"beam_masses_kg": [1.0, 0.0]}}, "sim.dynamics.beam_masses_kg.1"),
    ({"dynamics": {"link_stiffnes_n_per_m": 1e6}}, "sim.dynamics.link_stiffnes_n_per_m"),
    ({"seed": -1}, "sim.seed"),
    ({"module_name": "NI 0000"}, "sim.module_name"),
    ({"joint": "glue"}, "sim.joint"),
    ({"joint": {"family": "bouc_wen", "k0": 1e7, "alpha": 2e3, "beta": 2e3}}, "sim.joint.n"),
    ({"joint": {"family": "coulomb", "k": 0.0, "f_s": 10.0}}, "sim.joint.k"),
    ({"effects": [{"name": "visc", "c": 1.0}]}, "sim.effects[0].name"),
    ({"effects": [{"name": "viscous", "c": 1.0, "d": 2.0}]}, "sim.effects[0].d"),
    ({"effects": [{"name": "viscous"}]}, "sim.effects[0].c"),
    ({"effects": [{"name": "asymmetric_slip", "asym": 1.5}]}, "sim.effects[0].asym"),
    ({"effects": [{"name": "wear", "E_w": 1.0}, {"name": "wear", "E_w": 2.0}]}, "sim.effects[1].name"),
    ({"effects": [{"c": 1.0}]}, "sim.effects[0].name"),
])
def test_bad_sim_config_raises_config_error_naming_the_field(sim, field):
    with pytest.raises(ConfigError) as exc:
        SimConfig.from_dict(sim, source="rig.toml")
    assert exc.value.field == field
    assert "rig.toml" in str(exc.value)
