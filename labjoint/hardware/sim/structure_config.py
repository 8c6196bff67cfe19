"""Validated settings of the simulated structural rig (``[sim] rig = "structure"``).

Seed 000's clamped-free pipe assembly (two steel pipes joined by a threaded coupling),
reduced to a few modes, with a hidden hysteretic law at each thread, a shaker (armature,
suspension, coil with back-EMF, voltage amplifier) at the free end, a force sensor in the
stinger and accelerometers. Defaults match ``configs/structure-seed000.toml``'s assembly;
the threads' sticking stiffness puts mode 1 near 28.5 Hz (seed 000, measured).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from labjoint.errors import ConfigError

#: roles a channel can play besides an accelerometer (named by its sensor)
SIGNAL_ROLES = ("force", "drive_voltage", "amplifier_voltage")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class PipeConfig(_Strict):
    """One straight component: start, length, hollow circular section."""

    x_start_m: float = Field(ge=0)
    length_m: float = Field(gt=0)
    od_m: float = Field(gt=0)
    wall_m: float = Field(gt=0)

    @model_validator(mode="after")
    def _wall(self) -> "PipeConfig":
        if not self.wall_m < self.od_m / 2:
            raise ValueError(f"wall {self.wall_m} m must be less than half the OD {self.od_m} m")
        return self


class AssemblyConfig(_Strict):
    """Short pipe (clamped at x = 0), coupling, long pipe; threads at ``thread_x_m``."""

    E_pa: float = Field(215e9, gt=0)
    rho_kg_m3: float = Field(7800.0, gt=0)
    short_pipe: PipeConfig = PipeConfig(x_start_m=0.0, length_m=0.587, od_m=0.114, wall_m=0.0038)
    coupling: PipeConfig = PipeConfig(x_start_m=0.5445, length_m=0.085, od_m=0.122, wall_m=0.006)
    long_pipe: PipeConfig = PipeConfig(x_start_m=0.587, length_m=1.080, od_m=0.114, wall_m=0.0038)
    thread_x_m: tuple[float, float] = (0.567, 0.607)
    element_length_m: float = Field(0.03, gt=0)
    accelerometers: dict[str, tuple[Literal["short_pipe", "long_pipe", "coupling"], float]] = Field(
        default_factory=lambda: {"coupling_short_side": ("short_pipe", 0.540),
                                 "coupling_long_side": ("long_pipe", 0.634),
                                 "free_end": ("long_pipe", 1.667)})
    accelerometer_mass_kg: float = Field(0.020, ge=0)
    excitation_x_m: float = Field(1.667, gt=0, description="on the long pipe")
    modes: int = Field(4, ge=1, le=12, description="modes kept in the reduced model")
    damping_ratios: list[float] = Field(default_factory=lambda: [0.004], min_length=1,
                                        description="modal; the last one repeats")


class JointLawConfig(_Strict):
    """The hidden law at each thread, tangential at radius ``radius_m`` (u = r * relative rotation).

    ``richard_abbott``: seed 000's Eq. 2 backbone (initial stiffness the sticking one,
    k_p = ``residual_fraction`` of it, reference force ``slip_force_n``, exponent
    ``ra_exponent``) with Masing unloading and reloading;
    ``iwan``: Segalman's 4-parameter Iwan without its Dirac term (seed 001): Jenkins
    elements whose stiffness density over slip displacement is phi^chi up to phi_max,
    macro-slip at ``slip_force_n``; ``residual_fraction`` of the sticking stiffness stays
    elastic after macro-slip. With ``elements = 0`` (default) the continuous density,
    exact by Masing's rules with memory on its closed-form backbone
    (:mod:`.structure_iwan`); with N > 0 a deliberately discrete Iwan of N equal-stiffness
    sliders at the density's quantile midpoints (the lowest at phi_max / (2N)^(1/(1+chi)):
    linear below it). ``jenkins``: one element. ``viscous_ns_per_m`` adds c du/dt.
    """

    law: Literal["iwan", "jenkins", "richard_abbott", "linear"] = "iwan"
    rotational_stiffness_nm_per_rad: float = Field(5.3e5, gt=0, description="sticking k_theta")
    radius_m: float = Field(0.057, gt=0)
    slip_force_n: float = Field(15000.0, gt=0, description="macro-slip force of the hysteretic part")
    residual_fraction: float = Field(0.3, ge=0, lt=1)
    chi: float = Field(0.0, gt=-1, le=1)
    elements: int = Field(0, ge=0, le=200, description="0: the continuous density; N: N discrete sliders")
    viscous_ns_per_m: float = Field(0.0, ge=0)
    ra_exponent: float = Field(3.6, gt=0, description="Richard-Abbott n (seed 000 Table 4)")


class ShakerConfig(_Strict):
    """Electrodynamic shaker on a voltage amplifier: L di/dt + R i + Bl v = G V_gen."""

    armature_mass_kg: float = Field(0.3, gt=0)
    suspension_stiffness_n_per_m: float = Field(3.0e3, ge=0)
    suspension_damping_ns_per_m: float = Field(5.0, ge=0)
    coil_resistance_ohm: float = Field(2.0, gt=0)
    coil_inductance_h: float = Field(6.0e-4, ge=0)
    force_factor_n_per_a: float = Field(4.0, gt=0, description="Bl")
    amplifier_gain_v_per_v: float = Field(5.0, gt=0)


class StructureSensorsConfig(_Strict):
    """Sensor noise (rms, physical units) and DAQ input noise (V rms)."""

    force_noise_n: float = Field(0.01, ge=0)
    acceleration_noise_m_s2: float = Field(0.005, ge=0)
    voltage_noise_v: float = Field(1.0e-4, ge=0)
    current_noise_a: float = Field(1.0e-3, ge=0)
    daq_noise_v: float = Field(3.0e-5, ge=0)


class StructureSimConfig(_Strict):
    """All settings of the simulated structural rig."""

    rig: Literal["structure"] = "structure"
    seed: int = Field(0, ge=0)
    max_step_s: float = Field(2.5e-5, gt=0, le=1e-4)
    realtime: bool = False
    module_name: str = "NI 9234"
    assembly: AssemblyConfig = Field(default_factory=AssemblyConfig)
    joint: JointLawConfig = Field(default_factory=JointLawConfig)
    shaker: ShakerConfig = Field(default_factory=ShakerConfig)
    sensors: StructureSensorsConfig = Field(default_factory=StructureSensorsConfig)
    channel_roles: dict[str, str] = Field(default_factory=dict)

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None = None, source: str | None = None) -> "StructureSimConfig":
        """Validate a ``[sim]`` mapping; errors raise ConfigError naming ``sim.<field>``."""
        try:
            return cls.model_validate(dict(data or {}))
        except ValidationError as exc:
            err = exc.errors()[0]
            loc = ".".join(str(x) for x in err["loc"])
            raise ConfigError(err["msg"], file=source, field="sim." + loc if loc else "sim") from None

    @classmethod
    def from_rig(cls, rig_config: Any) -> "StructureSimConfig":
        """From a rig config's ``[sim]`` table (the DAQ module name unless set there)."""
        data = dict(getattr(rig_config, "sim", {}) or {})
        daq = getattr(rig_config, "daq", None)
        if daq is not None and "module_name" not in data:
            data["module_name"] = daq.module
        return cls.from_dict(data, source=getattr(rig_config, "source", None) or None)
