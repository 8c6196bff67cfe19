"""One interface per instrument: the signal generator and the DAQ.

Every backend (PyVISA driver on a real or pyvisa-sim instrument, nidaqmx, the physics
simulator) subclasses these; the abstract methods are enforced by :mod:`abc`.
Units: volts, hertz, seconds; samples as float64 volts shaped (n_channels, n).
"""

from __future__ import annotations

import abc
from dataclasses import asdict, dataclass, field

import numpy as np

from labjoint.errors import HardwareError, InputError

SENSOR_KINDS = ("force", "capacitive", "nanocomposite", "imported", "voltage", "accelerometer")
QUANTITIES = ("force", "displacement", "voltage", "time", "acceleration", "velocity")


@dataclass(frozen=True)
class ChannelSpec:
    """One analog input channel and the sensor on it.

    ``sensitivity`` converts volts to the physical unit (N/V or m/V).
    ``calibration`` optionally replaces it by a table of (frequency_hz, units_per_volt)
    pairs, interpolated at the run's excitation frequency (nanocomposite sensor).
    ``calibration_phase`` optionally holds (frequency_hz, phase_deg, uncertainty_deg):
    the phase by which the measured quantity leads the sensor's output, and its
    standard uncertainty, from the same calibration.
    """

    name: str
    sensor: str
    quantity: str
    unit: str
    sensitivity: float
    range_v: float = 5.0
    coupling: str = "AC"
    iepe: bool = False
    physical_channel: str = ""
    calibration: tuple[tuple[float, float], ...] = field(default_factory=tuple)
    calibration_phase: tuple[tuple[float, float, float], ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        if not self.name or not self.name.replace("_", "").isalnum():
            raise InputError(f"channel name {self.name!r} must be alphanumeric/underscore")
        if self.sensor not in SENSOR_KINDS:
            raise InputError(f"unknown sensor kind {self.sensor!r}; known: {SENSOR_KINDS}",
                             field=f"channels.{self.name}.sensor")
        imported_other = (self.sensor == "imported" and self.quantity.replace("_", "").isalnum()
                          and self.quantity.islower())    # imported: other quantities kept as given
        if self.quantity not in QUANTITIES and not imported_other:
            raise InputError(f"unknown quantity {self.quantity!r}; known: {QUANTITIES}",
                             field=f"channels.{self.name}.quantity")
        if not np.isfinite(self.sensitivity) or self.sensitivity == 0:
            raise InputError("sensitivity must be finite and non-zero",
                             field=f"channels.{self.name}.sensitivity")
        if not (self.range_v > 0):
            raise InputError("range must be positive", field=f"channels.{self.name}.range_v")
        if self.coupling not in ("AC", "DC"):
            raise InputError(f"coupling must be 'AC' or 'DC', got {self.coupling!r}",
                             field=f"channels.{self.name}.coupling")
        for row in self.calibration_phase:
            if len(row) != 3 or not all(np.isfinite(row[:2])) or not (row[2] >= 0):
                raise InputError("calibration_phase rows must be (frequency_hz, phase_deg, "
                                 f"uncertainty_deg >= 0), got {row!r}",
                                 field=f"channels.{self.name}.calibration_phase")

    def units_per_volt(self, frequency_hz: float | None = None) -> float:
        """Calibration factor at ``frequency_hz`` (table if given, else ``sensitivity``)."""
        if self.calibration and frequency_hz is not None and np.isfinite(frequency_hz):
            f, s = np.array(self.calibration, dtype=float).T
            order = np.argsort(f)
            return float(np.interp(frequency_hz, f[order], s[order]))
        return float(self.sensitivity)

    def phase_at(self, frequency_hz: float | None) -> tuple[float, float] | None:
        """Calibrated phase lead of the quantity over the sensor output at ``frequency_hz``
        and its standard uncertainty, both in rad (interpolated; None if not calibrated).

        >>> spec = ChannelSpec("nc", "nanocomposite", "force", "N", 301.0,
        ...                    calibration_phase=((200.0, 0.2, 0.02), (600.0, 0.6, 0.04)))
        >>> [round(float(np.degrees(v)), 3) for v in spec.phase_at(400.0)]
        [0.4, 0.03]
        """
        if not self.calibration_phase or frequency_hz is None or not np.isfinite(frequency_hz):
            return None
        f, ph, u = np.array(self.calibration_phase, dtype=float).T
        order = np.argsort(f)
        return (float(np.radians(np.interp(frequency_hz, f[order], ph[order]))),
                float(np.radians(np.interp(frequency_hz, f[order], u[order]))))

    def to_dict(self) -> dict:
        d = asdict(self)
        d["calibration"] = [list(p) for p in self.calibration]
        d["calibration_phase"] = [list(p) for p in self.calibration_phase]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "ChannelSpec":
        d = dict(d)
        d["calibration"] = tuple(tuple(float(x) for x in p) for p in d.get("calibration", ()))
        d["calibration_phase"] = tuple(tuple(float(x) for x in p)
                                       for p in d.get("calibration_phase", ()))
        return cls(**d)


@dataclass(frozen=True)
class GeneratorSettings:
    """What the function generator outputs: a sine (``shape`` "sine") or the loaded
    arbitrary waveform (``shape`` "user", repeated ``frequency_hz`` times per second,
    its peak at Vpp / 2), with its Vpp and offset."""

    frequency_hz: float
    amplitude_vpp: float
    offset_v: float = 0.0
    output: bool = False
    shape: str = "sine"


class SignalGenerator(abc.ABC):
    """A function generator channel producing a sine."""

    @abc.abstractmethod
    def identify(self) -> str:
        """Instrument identification string (``*IDN?``)."""

    @abc.abstractmethod
    def apply(self, frequency_hz: float, amplitude_vpp: float, offset_v: float = 0.0) -> GeneratorSettings:
        """Set a sine, read the settings back, compare, and return what was read."""

    @abc.abstractmethod
    def set_amplitude(self, amplitude_vpp: float) -> GeneratorSettings:
        """Change only the amplitude (frequency, offset, shape untouched: ramps), read it
        back, compare, and return the settings."""

    @abc.abstractmethod
    def set_output(self, on: bool) -> None:
        """Switch the output on or off (and confirm by read-back)."""

    @abc.abstractmethod
    def read_settings(self) -> GeneratorSettings:
        """Read the current settings back from the instrument."""

    @abc.abstractmethod
    def close(self) -> None:
        """Leave the output OFF and release the instrument."""

    # -- arbitrary waveforms: a capability; generators without it refuse ----------------
    def load_waveform(self, points: np.ndarray) -> int:
        """Load one period of an arbitrary waveform (normalised to a peak of 1, so that
        the amplitude setting is its peak); return the number of points stored."""
        raise HardwareError(f"{type(self).__name__} cannot play arbitrary waveforms")

    def apply_waveform(self, frequency_hz: float, amplitude_vpp: float,
                       offset_v: float = 0.0) -> GeneratorSettings:
        """Select the loaded waveform, repeated ``frequency_hz`` times per second, at
        ``amplitude_vpp`` (2 x its peak); read back, compare and return the settings."""
        raise HardwareError(f"{type(self).__name__} cannot play arbitrary waveforms")

    def waveform(self) -> np.ndarray | None:
        """The loaded waveform's points (peak 1), None if nothing is loaded."""
        return None

    def __enter__(self) -> "SignalGenerator":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class DAQ(abc.ABC):
    """A multi-channel analog input device with a continuous hardware clock."""

    @abc.abstractmethod
    def configure(self, channels: list[ChannelSpec], sample_rate_hz: float) -> float:
        """Set up channels and clock; return the actual sample rate the module offers."""

    @property
    @abc.abstractmethod
    def channels(self) -> list[ChannelSpec]:
        """The configured channels, in the row order of :meth:`read`."""

    @property
    @abc.abstractmethod
    def sample_rate_hz(self) -> float:
        """Actual sample rate."""

    @abc.abstractmethod
    def start(self) -> None:
        """Start continuous acquisition."""

    @abc.abstractmethod
    def read(self, n_samples: int, out: np.ndarray | None = None) -> np.ndarray:
        """Read the next ``n_samples`` per channel as volts, shape (n_channels, n).

        Raises :class:`labjoint.errors.BufferOverrun` if samples were lost.
        """

    @property
    @abc.abstractmethod
    def samples_read(self) -> int:
        """Total samples per channel delivered since :meth:`start` (the sample counter)."""

    @abc.abstractmethod
    def stop(self) -> None:
        """Stop acquisition (idempotent)."""

    @abc.abstractmethod
    def close(self) -> None:
        """Stop and release the device."""

    def __enter__(self) -> "DAQ":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    #: Host clock (POSIX seconds) when the acquisition started, i.e. at sample 0 of the
    #: sample counter, and how long the start call took (its uncertainty); None if the
    #: backend does not know. Sample k was taken at about ``started_at + k / rate``.
    started_at: float | None = None
    started_at_uncertainty_s: float | None = None
