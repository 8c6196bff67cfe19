"""Validated settings of the simulated rig (the ``[sim]`` table of a rig config).

Every parameter has a physically sensible default, so ``[sim] seed = 0`` is a complete
configuration. Defaults are tuned to seed 002's rig: at 400 Hz, 20 Vpp and 5 Nm the joint
is in micro-slip (relative displacement ~7 um, joint force ~90 N, loop secant stiffness
~12.6 MN/m, cf. Table 2: 11.8 MN/m); at 100 Hz, 20 Vpp and 2 Nm it reaches macro-slip
(the friction test of Eq. 10, mu = 161.1 / 956.3).

Tables (all optional)::

    [sim]
    seed = 0                     # noise streams; the physics is deterministic
    joint = "seed002"            # or "dry_microslip", {family = "coulomb", k = 1e7, f_s = 50.0}, "none"
    effects = [{name = "viscous", c = 200.0}]   # vocabulary names and parameters (SI)
    max_step_s = 1e-5            # integration step bound (or substeps = n per sample)
    realtime = false             # pace DAQ reads to the sample clock
    module_name = "NI 9233"      # from [daq] module when built with from_rig
    channel_roles = {shear_nc = "joint_force"}  # from [rig] when built with from_rig
    [sim.dynamics]   shaker, amplifier, link and beam parameters (SI)
    [sim.contact]    bolt radius, contact ratio, mu, torque, shear-layer stiffness, rings
    [sim.sensors]    noise per channel kind, nanocomposite response
    [sim.module]     override the DAQ module's rate ladder / coupling (else from daq.module)
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, PrivateAttr, ValidationError

from labjoint.errors import ConfigError
from labjoint.hardware.sim.effects import JointSpec, parse_joint
from labjoint.hardware.sim.modules import ModuleSpec, get_module

ROLES = ("force_ref", "force_ref_2", "disp_1", "disp_2", "joint_force", "drive_voltage")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class DynamicsConfig(_Strict):
    """Shakers (B&K 4808 class), power amplifiers (current mode), links and beams; SI units.

    The link (stinger + reference force sensor) is compliant enough that its resonance
    with the shaker armature (~230 Hz) lies between the friction test (100 Hz) and the
    reference test (400 Hz), as on the seed 002 rig where 100 Hz reaches macro-slip.
    """

    armature_mass_kg: float = Field(0.375, gt=0)
    suspension_stiffness_n_per_m: float = Field(2.0e4, ge=0)
    suspension_damping_ns_per_m: float = Field(40.0, ge=0)
    amplifier_gain_a_per_v: float = Field(1.4, gt=0)
    force_constant_n_per_a: float = Field(10.0, gt=0)
    shaker_balance: float = Field(1.0, gt=0, description="force of shaker 2 / shaker 1 (antiphase)")
    link_stiffness_n_per_m: float = Field(8.0e5, gt=0)
    link_damping_ns_per_m: float = Field(10.0, ge=0)
    beam_masses_kg: tuple[PositiveFloat, PositiveFloat] = (1.0, 1.0)
    support_stiffness_n_per_m: float = Field(1.0e5, ge=0)
    support_damping_ns_per_m: float = Field(100.0, ge=0)


class ContactConfig(_Strict):
    """Bolted contact (seed 002 Eqs. 2-4, Table 1, Sec. IV-A) and the shear layer in series.

    ``shear_stiffness_n_per_m`` is the rings' total sticking stiffness; unset, it is the
    joint preset's: 14 MN/m for ``dry_microslip`` (the loop slope of Table 2 alone) and
    40 MN/m for ``seed002``, whose viscoelastic layer (k_l, c_l) in series brings the
    joint to Table 2's complex stiffness at 400 Hz: 1 / (1/(k_l + i w c_l) + 1/K_c) =
    11.8 MN/m + i w 1.8 kNs/m (K and C of the hysteresis loop, Tables 2-3). The
    nanocomposite (PVDF/CNT) film between the plates is that layer; its loss factor
    w c_l / k_l = 0.58 at 400 Hz is derived from the paper's measured joint, not a
    datasheet.
    """

    bolt_radius_m: float = Field(5.0e-3, gt=0)
    contact_ratio: float = Field(3.5, gt=1.0, description="a / r_b")
    friction_coefficient: float = Field(0.168, gt=0)
    torque_nm: float = Field(5.0, gt=0)
    torque_to_normal_n_per_nm: float = Field(478.0, gt=0)
    shear_stiffness_n_per_m: float | None = Field(None, gt=0, description="total sticking stiffness of the rings")
    layer_stiffness_n_per_m: float = Field(15.3e6, gt=0, description="seed002 shear layer k_l")
    layer_damping_ns_per_m: float = Field(3.53e3, ge=0, description="seed002 shear layer c_l")
    rings: int = Field(60, ge=2, le=2000)
    edge_refinement: float = Field(1e-4, gt=0, lt=1)


class NanocompositeConfig(_Strict):
    """PVDF/CNT sensor: V/N = H(f), |H(reference_hz)| = 1/factor_n_per_v.

    H(s) = G (s + shelf_ratio w_s)/(s + w_s) * w_r^2/(s^2 + 2 zeta w_r s + w_r^2): a
    piezoresistive low-frequency shelf (sensitivity x shelf_ratio at DC) and a layer
    resonance at resonance_hz; flat within ~1 % from 50 Hz to 1.5 kHz.
    """

    factor_n_per_v: float = Field(301.0, gt=0)
    reference_hz: float = Field(400.0, gt=0)
    shelf_ratio: float = Field(0.6, gt=0)
    shelf_hz: float = Field(8.0, gt=0)
    resonance_hz: float = Field(12000.0, gt=0)
    resonance_damping: float = Field(0.15, gt=0)


class SensorsConfig(_Strict):
    """Noise (rms, in the sensor's physical unit) per channel kind, plus DAQ input noise."""

    force_noise_n: float = Field(0.02, ge=0)
    displacement_noise_m: float = Field(2.0e-9, ge=0)
    nanocomposite_noise_n: float = Field(0.3, ge=0)
    voltage_noise_v: float = Field(1.0e-4, ge=0)
    daq_noise_v: float = Field(3.0e-5, ge=0)
    nanocomposite: NanocompositeConfig = Field(default_factory=NanocompositeConfig)


class ModuleConfig(_Strict):
    """A DAQ module other than the known ones (see :mod:`.modules`)."""

    name: str = "custom"
    base_rate_hz: float = Field(gt=0)
    max_divisor: int = Field(1, ge=1)
    couplings: tuple[Literal["AC", "DC"], ...] = ("AC", "DC")
    ac_cutoff_hz: float = Field(0.5, gt=0)
    bits: int = Field(24, ge=8, le=32)


class SimConfig(_Strict):
    """All settings of the simulated rig; build with :meth:`from_rig` or :meth:`from_dict`."""

    seed: int = Field(0, ge=0)
    max_step_s: float = Field(1.0e-5, gt=0, le=1e-4, description="largest integration step")
    substeps: int | None = Field(None, ge=1, le=1000, description="per sample; default from max_step_s")
    realtime: bool = False
    module_name: str = "NI 9233"
    module: ModuleConfig | None = None
    dynamics: DynamicsConfig = Field(default_factory=DynamicsConfig)
    contact: ContactConfig = Field(default_factory=ContactConfig)
    sensors: SensorsConfig = Field(default_factory=SensorsConfig)
    joint: str | dict[str, Any] = "seed002"
    effects: list[dict[str, Any]] = Field(default_factory=list)
    channel_roles: dict[str, Literal[ROLES]] = Field(default_factory=dict)  # type: ignore[valid-type]

    _joint: JointSpec | None = PrivateAttr(None)

    @property
    def joint_spec(self) -> JointSpec:
        """The parsed joint law and injected effects (ConfigError names the bad field)."""
        if self._joint is None:
            self._joint = parse_joint(self.joint, self.effects)
        return self._joint

    @property
    def module_spec(self) -> ModuleSpec:
        if self.module is not None:
            m = self.module
            return ModuleSpec(m.name, m.base_rate_hz, m.max_divisor, tuple(m.couplings), m.ac_cutoff_hz, m.bits)
        return get_module(self.module_name)

    @property
    def ring_stiffness_n_per_m(self) -> float:
        """The rings' total sticking stiffness: set, or the joint preset's (ContactConfig)."""
        k = self.contact.shear_stiffness_n_per_m
        if k is not None:
            return float(k)
        return 40.0e6 if self.joint_spec.layer else 14.0e6

    @property
    def layer(self) -> tuple[float, float] | None:
        """(k_l, c_l) of the series shear layer of the ``seed002`` joint, else None."""
        c = self.contact
        return (c.layer_stiffness_n_per_m, c.layer_damping_ns_per_m) if self.joint_spec.layer else None

    @property
    def normal_force_n(self) -> float:
        return self.contact.torque_nm * self.contact.torque_to_normal_n_per_nm

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None = None, source: str | None = None) -> "SimConfig":
        """Validate a ``[sim]`` mapping; errors raise ConfigError naming ``sim.<field>``."""
        try:
            cfg = cls.model_validate(dict(data or {}))
        except ValidationError as exc:
            err = exc.errors()[0]
            loc = ".".join(str(x) for x in err["loc"])
            raise ConfigError(err["msg"], file=source, field="sim." + loc if loc else "sim") from None
        try:
            cfg.joint_spec
            if cfg.module is None:
                get_module(cfg.module_name)
        except ConfigError as exc:
            field = exc.field or ""
            field = "sim.module_name" if field == "daq.module" else field
            raise ConfigError(exc.message, file=source, field=field) from None
        return cfg

    @classmethod
    def from_rig(cls, rig_config: Any) -> "SimConfig":
        """Build from a :class:`labjoint.config.RigConfig` (read duck-typed: this layer is below config).

        Takes ``rig_config.sim``, the DAQ module name, the torque-to-normal ratio and the
        channel roles named in ``rig_config.rig`` unless the ``[sim]`` table sets them.
        """
        data = dict(getattr(rig_config, "sim", {}) or {})
        rig = getattr(rig_config, "rig", None)
        daq = getattr(rig_config, "daq", None)
        source = getattr(rig_config, "source", None) or None
        if daq is not None and "module_name" not in data and "module" not in data:
            data["module_name"] = daq.module
        if rig is not None:
            contact = dict(data.get("contact", {}) or {})
            contact.setdefault("torque_to_normal_n_per_nm", rig.torque_to_normal_n_per_nm)
            data["contact"] = contact
            roles = dict(data.get("channel_roles", {}) or {})
            d1, d2 = rig.displacement_channels
            for name, role in ((rig.reference_force_channel, "force_ref"), (d1, "disp_1"), (d2, "disp_2"),
                               (rig.joint_force_channel, "joint_force")):
                roles.setdefault(name, role)
            data["channel_roles"] = roles
        return cls.from_dict(data, source=source)
