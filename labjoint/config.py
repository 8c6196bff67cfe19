"""Rig configuration (TOML), validated with pydantic; errors name the file and field.

The ``[sim]`` table is kept as a plain mapping here and validated by the simulator
itself when config selects it, so nothing here imports the simulator.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec

#: Repository (or editable-install) configs folder.
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"
DEFAULT_CONFIG = CONFIG_DIR / "rig-sim.toml"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class ChannelConfig(_Strict):
    name: str
    sensor: Literal["force", "capacitive", "nanocomposite", "voltage"]
    quantity: Literal["force", "displacement", "voltage"]
    unit: str
    sensitivity: float
    range_v: float = 5.0
    coupling: Literal["AC", "DC"] = "AC"
    iepe: bool = False
    physical_channel: str = ""
    calibration: list[tuple[float, float]] = Field(default_factory=list)

    def spec(self) -> ChannelSpec:
        d = self.model_dump()
        d["calibration"] = tuple(tuple(p) for p in d["calibration"])
        return ChannelSpec(**d)


class GeneratorConfig(_Strict):
    resource: str = "USB0::0x0699::0x0353::SIM0001::INSTR"
    visa_library: str = ""
    timeout_ms: int = Field(2000, gt=0)
    channel: Literal[1, 2] = 1


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


class RigSection(_Strict):
    backend: Literal["sim", "real"] = "sim"
    torque_to_normal_n_per_nm: float = Field(478.0, gt=0)
    joint_force_channel: str = "shear_nc"
    reference_force_channel: str = "force_ref"
    displacement_channels: tuple[str, str] = ("disp_1", "disp_2")
    data_dir: str = "data"


class RigConfig(_Strict):
    rig: RigSection = Field(default_factory=RigSection)
    generator: GeneratorConfig = Field(default_factory=GeneratorConfig)
    daq: DAQConfig
    limits: LimitsConfig = Field(default_factory=LimitsConfig)
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
    try:
        with open(p, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError("config file not found", file=str(p)) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", file=str(p)) from None
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
