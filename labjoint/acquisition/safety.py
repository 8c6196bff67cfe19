"""The one place where the rig's safety limits are checked.

The engine calls :func:`check_settings` before every change of the generator and
:func:`check_block` on every block it acquires; plans never check limits. A violation
raises :class:`LimitTrip` (a :class:`~labjoint.errors.LimitExceeded`) naming the limit,
the channel if any, and the measured or requested value.

>>> from labjoint.config import LimitsConfig
>>> from labjoint.hardware.interfaces import GeneratorSettings
>>> check_settings(GeneratorSettings(400.0, 25.0), LimitsConfig())
Traceback (most recent call last):
...
labjoint.acquisition.safety.LimitTrip: amplitude 25 Vpp exceeds max_vpp = 20 Vpp
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from labjoint.config import LimitsConfig
from labjoint.errors import LimitExceeded
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings


class LimitTrip(LimitExceeded):
    """A limit was exceeded: ``limit`` (config field), ``value`` (measured or requested),
    ``bound`` (the limit's value), and for a block the ``channel`` and the column
    ``index`` of the largest excursion."""

    def __init__(self, message: str, *, limit: str, value: float, bound: float,
                 channel: str | None = None, index: int | None = None) -> None:
        super().__init__(message)
        self.limit = limit
        self.value = float(value)
        self.bound = float(bound)
        self.channel = channel
        self.index = index

    def to_dict(self) -> dict:
        return {"limit": self.limit, "value": self.value, "bound": self.bound,
                "channel": self.channel, "index": self.index}


def check_settings(settings: GeneratorSettings, limits: LimitsConfig,
                   band_hz: tuple[float, float] | None = None) -> None:
    """Refuse generator settings outside the amplitude and frequency limits; an arbitrary
    waveform (``shape`` "user") is checked by the band it holds (``band_hz``), not by its
    repetition frequency."""
    vpp, f = float(settings.amplitude_vpp), float(settings.frequency_hz)
    if not math.isfinite(vpp) or vpp < 0:
        raise LimitTrip(f"amplitude {vpp:g} Vpp is not within 0..max_vpp = {limits.max_vpp:g} Vpp",
                        limit="max_vpp", value=vpp, bound=limits.max_vpp)
    if vpp > limits.max_vpp:
        raise LimitTrip(f"amplitude {vpp:g} Vpp exceeds max_vpp = {limits.max_vpp:g} Vpp",
                        limit="max_vpp", value=vpp, bound=limits.max_vpp)
    lo, hi, what = f, f, "frequency"
    if getattr(settings, "shape", "sine") == "user":
        if band_hz is None or not (math.isfinite(f) and f > 0):
            raise LimitTrip("an arbitrary waveform needs its band (lowest and highest frequency) "
                            "to be checked against the frequency limits",
                            limit="max_frequency_hz", value=float("nan"), bound=limits.max_frequency_hz)
        lo, hi = float(band_hz[0]), float(band_hz[1])
        what = "the waveform's band reaches"
    if not math.isfinite(lo) or lo < limits.min_frequency_hz:
        raise LimitTrip(f"{what} {lo:g} Hz is below min_frequency_hz = {limits.min_frequency_hz:g} Hz",
                        limit="min_frequency_hz", value=lo, bound=limits.min_frequency_hz)
    if not math.isfinite(hi) or hi > limits.max_frequency_hz:
        raise LimitTrip(f"{what} {hi:g} Hz exceeds max_frequency_hz = {limits.max_frequency_hz:g} Hz",
                        limit="max_frequency_hz", value=hi, bound=limits.max_frequency_hz)
    if not math.isfinite(float(settings.offset_v)):
        raise LimitTrip(f"offset_v {settings.offset_v!r} V is not finite",
                        limit="offset_v", value=float("nan"), bound=0.0)


def check_frequency_step(previous_hz: float, new_hz: float, limits: LimitsConfig) -> None:
    """Refuse a frequency update with the output on larger than ``max_frequency_step``
    (relative to the previous frequency), when the rig sets one: a sine jumping far with
    the output on drives the structure through a transient of unknown size. Closed-loop
    plans (phase_resonance's step clip) stay below it by design.

    >>> check_frequency_step(30.0, 30.3, LimitsConfig(max_frequency_step=0.02))
    >>> check_frequency_step(30.0, 33.0, LimitsConfig(max_frequency_step=0.02))
    Traceback (most recent call last):
    ...
    labjoint.acquisition.safety.LimitTrip: frequency step 30 -> 33 Hz (10%) exceeds max_frequency_step = 2%
    """
    bound = limits.max_frequency_step
    if bound is None:
        return
    step = abs(new_hz - previous_hz) / previous_hz
    if not step <= bound:
        raise LimitTrip(f"frequency step {previous_hz:g} -> {new_hz:g} Hz ({step:.0%}) exceeds "
                        f"max_frequency_step = {bound:.0%}", limit="max_frequency_step", value=step,
                        bound=bound)


def check_force_target(force_n: float, limits: LimitsConfig, name: str = "force_amplitude_n") -> None:
    """Refuse a force a plan asks the rig to reach (a closed-loop target such as
    step_sine's ``force_amplitude_n``) above ``max_force_n``: the loop would drive the
    generator to its limit chasing it.

    >>> from labjoint.config import LimitsConfig
    >>> check_force_target(1e6, LimitsConfig())
    Traceback (most recent call last):
    ...
    labjoint.acquisition.safety.LimitTrip: force_amplitude_n = 1e+06 N exceeds max_force_n = 1000 N
    """
    f = float(force_n)
    if not (math.isfinite(f) and abs(f) <= limits.max_force_n):
        raise LimitTrip(f"{name} = {f:g} N exceeds max_force_n = {limits.max_force_n:g} N",
                        limit="max_force_n", value=f, bound=limits.max_force_n)


def check_block(volts: np.ndarray, channels: Sequence[ChannelSpec], limits: LimitsConfig,
                frequency_hz: float | None = None, relative: Sequence[str] | None = None) -> None:
    """Refuse a block whose peak displacement (any displacement channel, and the relative
    displacement ``x_a - x_b`` of the two channels named in ``relative``) or peak force
    (any force channel) exceeds the limits; volts are scaled by each channel's
    calibration at ``frequency_hz``."""
    volts = np.asarray(volts)
    if volts.ndim != 2 or volts.shape[0] != len(channels) or volts.shape[1] == 0:
        return
    rows = []
    for row, spec in enumerate(channels):
        if spec.quantity in ("displacement", "force"):
            rows.append((spec.name, spec.quantity, volts[row] * spec.units_per_volt(frequency_hz)))
    if relative is not None and len(relative) == 2:
        index = {c.name: i for i, c in enumerate(channels)}
        a, b = (index[n] for n in relative)
        x = (volts[a] * channels[a].units_per_volt(frequency_hz)
             - volts[b] * channels[b].units_per_volt(frequency_hz))
        rows.append((f"{relative[0]}-{relative[1]}", "displacement", x))
    for name, quantity, x in rows:
        if quantity == "displacement":
            limit, bound, unit = "max_displacement_m", limits.max_displacement_m, "m"
        else:
            limit, bound, unit = "max_force_n", limits.max_force_n, "N"
        col = int(np.argmax(np.abs(x)))
        value = abs(float(x[col]))
        if not value <= bound:  # NaN trips too
            raise LimitTrip(f"{quantity} on {name} reached {value:.4g} {unit}, "
                            f"over {limit} = {bound:.4g} {unit}",
                            limit=limit, value=value, bound=bound, channel=name, index=col)
