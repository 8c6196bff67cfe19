"""Rig configuration (TOML), validated with pydantic; errors name the file and field.

The ``[sim]`` table is kept as a plain mapping here and validated by the simulator
itself when config selects it, so nothing here imports the simulator.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import (BaseModel, ConfigDict, Field, ValidationError, ValidationInfo,
                      field_validator)

from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.tomlfile import read_toml

#: Repository (or editable-install) configs folder.
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"
DEFAULT_CONFIG = CONFIG_DIR / "rig-sim.toml"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class ChannelConfig(_Strict):
    name: str
    sensor: Literal["force", "capacitive", "nanocomposite", "voltage", "accelerometer"]
    quantity: Literal["force", "displacement", "voltage", "acceleration"]
    unit: str
    sensitivity: float
    range_v: float = 5.0
    coupling: Literal["AC", "DC"] = "AC"
    iepe: bool = False
    physical_channel: str = ""
    calibration: list[tuple[float, float]] = Field(default_factory=list)
    #: (frequency_hz, phase_deg, uncertainty_deg): the quantity's lead over the output
    calibration_phase: list[tuple[float, float, float]] = Field(default_factory=list)

    def spec(self) -> ChannelSpec:
        d = self.model_dump()
        d["calibration"] = tuple(tuple(p) for p in d["calibration"])
        d["calibration_phase"] = tuple(tuple(p) for p in d["calibration_phase"])
        return ChannelSpec(**d)


class GeneratorConfig(_Strict):
    resource: str = "USB0::0x0699::0x0353::SIM0001::INSTR"
    visa_library: str = ""
    timeout_ms: int = Field(2000, gt=0)
    channel: Literal[1, 2] = 1
    #: the load the amplitude refers to: "INF" (high-Z amplifier input) or "50" ohm; sent
    #: to the instrument only where it accepts OUTPut<n>:IMPedance (probed at connect),
    #: else set the same on the front panel
    load: Literal["INF", "50"] = "INF"


class DAQConfig(_Strict):
    module: str = "NI 9233"
    device: str = "cDAQ1Mod1"
    sample_rate_hz: float = Field(50000.0, gt=0)
    block_samples: int = Field(5000, gt=0)
    channels: list[ChannelConfig]

    @field_validator("channels")
    @classmethod
    def _unique(cls, v: list[ChannelConfig]) -> list[ChannelConfig]:
        names = [c.name for c in v]
        if len(set(names)) != len(names):
            raise ValueError(f"channel names must be unique, got {names}")
        return v

    def specs(self) -> list[ChannelSpec]:
        return [c.spec() for c in self.channels]


class LimitsConfig(_Strict):
    max_vpp: float = Field(20.0, gt=0)
    min_frequency_hz: float = Field(1.0, gt=0)
    max_frequency_hz: float = Field(5000.0, gt=0)
    max_displacement_m: float = Field(200e-6, gt=0)
    max_force_n: float = Field(1000.0, gt=0)
    ramp_vpp_per_s: float = Field(40.0, gt=0)
    max_record_s: float = Field(600.0, gt=0)
    #: largest relative frequency change in one update while the output is on (None: any)
    max_frequency_step: float | None = Field(None, gt=0)


class PlausibilityConfig(_Strict):
    """Limits of what the pipelines take as a joint's measurement (``[plausibility]``);
    None: labjoint.identify.plausible's default (0.01 m; 10 samples per period; 0.5 % of
    W lost to the low-pass; 0.5 % frequency mismatch). The CLI's ``--max-displacement M``
    overrides the first."""

    max_displacement_amplitude_m: float | None = Field(None, gt=0)
    min_samples_per_period: float | None = Field(None, gt=0)
    max_filter_loss: float | None = Field(None, gt=0, lt=1)
    max_frequency_mismatch: float | None = Field(None, gt=0, lt=1)


#: Contact-zone outer radius over bolt radius, a = 3.5 r_b (seed 002 Eq. 2 / Sec. II.B).
CONTACT_RATIO = 3.5


class RigSection(_Strict):
    """Backend, channel roles, data directory and the rig's geometry (SI units).

    The geometry is written into every run's metadata by the run engine, so the
    identification pipelines read it from the file: the stick-slip method (seed 002
    Eqs. 2-9) the bolt radius r_b and contact radius a; the sensor calibration the mass
    of beam 1 between the reference force sensor and the joint and that beam's support
    stiffness/damping (to remove F = m a + k_s x + c_s v from the reference force); the
    friction test (Eq. 10) the torque-to-normal-force ratio. Defaults are seed 002's
    (478 N/Nm, a = 3.5 r_b) and the simulated rig's (M10 bolt r_b = 5 mm, 1 kg beams,
    support 1e5 N/m and 100 N s/m); measure them on a real rig.
    """

    backend: Literal["sim", "real"] = "sim"
    torque_to_normal_n_per_nm: float = Field(478.0, gt=0, allow_inf_nan=False)
    joint_force_channel: str | None = "shear_nc"    # None: no interfacial force sensor
    reference_force_channel: str = "force_ref"
    #: none on a structural rig read by accelerometers (steady state is then judged on them)
    displacement_channels: tuple[str, str] | tuple[()] = ("disp_1", "disp_2")
    data_dir: str = "data"
    #: the run catalog: "" = the SQLite file data_dir/catalog.sqlite; a
    #: postgresql://user@host:port/db URL = a PostgreSQL catalog several machines share
    #: (the password best in ~/.pgpass or PGPASSWORD, not in this file)
    catalog_url: str = ""
    bolt_radius_m: float = Field(5.0e-3, gt=0, allow_inf_nan=False,
                                 description="bolt radius r_b (m)")
    contact_radius_m: float | None = Field(
        None, gt=0, allow_inf_nan=False,
        description="contact-zone outer radius a (m); default 3.5 r_b (seed 002)")
    beam_mass_kg: float = Field(1.0, gt=0, allow_inf_nan=False,
                                description="beam-1 mass between reference sensor and joint (kg)")
    beam_support_stiffness_n_per_m: float = Field(
        1.0e5, ge=0, allow_inf_nan=False, description="beam-1 support stiffness (N/m), 0: free")
    beam_support_damping_ns_per_m: float = Field(
        100.0, ge=0, allow_inf_nan=False, description="beam-1 support damping (N s/m), 0: none")

    @field_validator("catalog_url")
    @classmethod
    def _postgres_url(cls, url: str) -> str:
        if url and not url.startswith(("postgresql://", "postgres://")):
            raise ValueError("must be empty (the SQLite catalog in data_dir) or a "
                             "postgresql://user@host:port/database URL")
        return url

    @field_validator("contact_radius_m")
    @classmethod
    def _contact_inside_pressure_zero(cls, a: float | None, info: ValidationInfo) -> float | None:
        rb = info.data.get("bolt_radius_m")
        if a is not None and rb is not None and not (rb < a <= CONTACT_RATIO * rb):
            raise ValueError(f"contact radius a = {a} m must lie in (r_b, {CONTACT_RATIO} r_b] = "
                             f"({rb}, {CONTACT_RATIO * rb}] m: Eq. 2's pressure is zero "
                             "beyond 3.5 r_b (seed 002)")
        return a

    @property
    def contact_radius(self) -> float:
        """Contact-zone outer radius a (m): the configured one, else 3.5 r_b."""
        return (CONTACT_RATIO * self.bolt_radius_m if self.contact_radius_m is None
                else float(self.contact_radius_m))

    def geometry(self) -> dict[str, float]:
        """The run-metadata keys the identification pipelines read (SI units).

        >>> g = RigSection().geometry()
        >>> g["contact_radius_m"], g["torque_to_normal_n_per_nm"]
        (0.0175, 478.0)
        """
        return {"bolt_radius_m": float(self.bolt_radius_m),
                "contact_radius_m": self.contact_radius,
                "beam_mass_kg": float(self.beam_mass_kg),
                "beam_support_stiffness_n_per_m": float(self.beam_support_stiffness_n_per_m),
                "beam_support_damping_ns_per_m": float(self.beam_support_damping_ns_per_m),
                "torque_to_normal_n_per_nm": float(self.torque_to_normal_n_per_nm)}


class RigConfig(_Strict):
    rig: RigSection = Field(default_factory=RigSection)
    generator: GeneratorConfig = Field(default_factory=GeneratorConfig)
    daq: DAQConfig
    limits: LimitsConfig = Field(default_factory=LimitsConfig)
    plausibility: PlausibilityConfig = Field(default_factory=PlausibilityConfig)
    sim: dict[str, Any] = Field(default_factory=dict)
    #: the REST service's settings, validated by labjoint.api.settings (a higher layer)
    api: dict[str, Any] = Field(default_factory=dict)
    source: str = ""

    def normal_force_n(self, torque_nm: float) -> float:
        """Bolt normal force from tightening torque (seed 002: 478 N/Nm)."""
        if not torque_nm > 0:
            raise ConfigError(f"torque must be positive, got {torque_nm} Nm", field="torque_nm")
        return self.rig.torque_to_normal_n_per_nm * torque_nm


def load_config(path: str | Path | None = None, overrides: dict[str, Any] | None = None) -> RigConfig:
    """Read and validate a rig config (default: the simulated rig)."""
    p = Path(path) if path is not None else DEFAULT_CONFIG
    data = read_toml(p, ConfigError, "config file")
    if overrides:
        data = _merge(data, overrides)
    data["source"] = str(p)
    return parse_config(data, source=str(p))


def parse_config(data: dict[str, Any], source: str = "<config>") -> RigConfig:
    try:
        return RigConfig.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(x) for x in err["loc"])
        raise ConfigError(err["msg"], file=source, field=loc) from None


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = v
    return out
