"""What NI C Series analog-input modules offer, and the checks of a rig's DAQ against it.

:class:`ModuleSpec` per module (couplings, IEPE excitation, input range, the sample
rates a delta-sigma module offers, where AC coupling is flat), :func:`offered_rate`,
:func:`check_channels` and :func:`check_drive_band`: pure checks, no driver needed, used
by :mod:`labjoint.hardware.nidaq` before a task is made and by ``labjoint check`` on a
config. Figures from the NI 9233/9234/9239/9215 specifications.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labjoint.errors import ConfigError, InputError
from labjoint.hardware.interfaces import ChannelSpec

IEPE_CURRENT_A = 0.002  # NI 9233/9234 internal IEPE excitation


@dataclass(frozen=True)
class ModuleSpec:
    """What a C Series module offers: couplings, IEPE, input range, sample rates.

    ``rate_base_hz`` and ``max_divider`` describe delta-sigma modules whose rates are
    ``rate_base_hz / n``, n = 1..max_divider; ``max_divider = 0`` means any rate up to
    ``rate_base_hz``.
    """

    couplings: tuple[str, ...]
    iepe: bool
    range_v: float
    rate_base_hz: float
    max_divider: int
    #: IEPE excitation switchable per channel (else every input gets it)
    iepe_switchable: bool = False
    #: AC coupling: above this frequency the response is within 0.1 dB (datasheet)
    ac_flat_from_hz: float = 0.0

    def rates(self) -> np.ndarray:
        """Offered rates, ascending (empty for modules with a continuous rate range)."""
        if self.max_divider == 0:
            return np.empty(0)
        return self.rate_base_hz / np.arange(self.max_divider, 0, -1)


MODULES = {
    # AC cutoff (NI 9233/9234 specifications): -3 dB 0.5 Hz, -0.1 dB 4.6 Hz max; the
    # passband is flat to 0.45 fs (the response depends on frequency and sample rate).
    "NI 9233": ModuleSpec(("AC",), True, 5.0, 50_000.0, 25, False, 4.6),
    "NI 9234": ModuleSpec(("AC", "DC"), True, 5.0, 51_200.0, 31, True, 4.6),
    "NI 9239": ModuleSpec(("DC",), False, 10.0, 50_000.0, 31),
    "NI 9215": ModuleSpec(("DC",), False, 10.0, 100_000.0, 0),
}


def module_spec(module: str) -> ModuleSpec:
    try:
        return MODULES[module]
    except KeyError:
        raise ConfigError(f"unknown DAQ module {module!r}; known: {sorted(MODULES)}",
                          field="daq.module") from None


def offered_rate(module: str, requested_hz: float) -> float:
    """The rate the module runs at for a request: the nearest offered rate at or above it
    (delta-sigma modules); a rate outside what the module offers is refused.

    >>> offered_rate("NI 9233", 50000.0)
    50000.0
    >>> offered_rate("NI 9233", 10000.0)
    10000.0
    >>> round(offered_rate("NI 9233", 7000.0), 3)   # 50 kS/s / 7
    7142.857
    """
    spec = module_spec(module)
    r = float(requested_hz)
    top = spec.rate_base_hz
    if not (np.isfinite(r) and 0 < r <= top * (1 + 1e-12)):
        raise InputError(f"{module} samples at up to {top:g} S/s per channel, got {requested_hz!r}",
                         field="daq.sample_rate_hz")
    rates = spec.rates()
    if rates.size == 0:
        return r
    if r < rates[0] * (1 - 1e-12):
        raise InputError(f"{module} offers {rates[0]:g}..{top:g} S/s ({top:g}/n, n = 1.."
                         f"{spec.max_divider}), got {requested_hz!r}", field="daq.sample_rate_hz")
    return float(rates[np.searchsorted(rates, r * (1 - 1e-12))])


def check_channels(module: str, channels: list[ChannelSpec]) -> None:
    """Refuse channels the module cannot measure (coupling, IEPE, range, duplicates)."""
    spec = module_spec(module)
    if not channels:
        raise ConfigError("at least one channel is needed", field="daq.channels")
    seen: dict[str, str] = {}
    for i, ch in enumerate(channels):
        where = f"daq.channels.{ch.name}"
        if ch.coupling not in spec.couplings:
            raise ConfigError(f"{module} is {'/'.join(spec.couplings)}-coupled only; "
                              f"channel {ch.name!r} asks for {ch.coupling}", field=f"{where}.coupling")
        if ch.iepe and not spec.iepe:
            raise ConfigError(f"{module} has no IEPE excitation; channel {ch.name!r} asks for it",
                              field=f"{where}.iepe")
        if spec.iepe and not spec.iepe_switchable and not ch.iepe:
            raise ConfigError(f"{module} sources 2 mA IEPE current on every input (not "
                              f"switchable); channel {ch.name!r} ({ch.sensor}) has iepe = false "
                              "and must not be fed it: wire it to a module that switches "
                              "excitation off (NI 9234) or has none (NI 9239, NI 9215)",
                              field=f"{where}.iepe")
        if ch.iepe and ch.coupling != "AC":
            raise ConfigError(f"IEPE needs AC coupling; channel {ch.name!r} is {ch.coupling}",
                              field=f"{where}.coupling")
        if ch.range_v > spec.range_v * (1 + 1e-12):
            raise ConfigError(f"{module} measures +-{spec.range_v:g} V; channel {ch.name!r} asks "
                              f"for +-{ch.range_v:g} V", field=f"{where}.range_v")
        phys = ch.physical_channel or f"ai{i}"
        if phys in seen:
            raise ConfigError(f"channels {seen[phys]!r} and {ch.name!r} share {phys}",
                              field=f"{where}.physical_channel")
        seen[phys] = ch.name


def check_drive_band(module: str, channels: list[ChannelSpec], sample_rate_hz: float,
                     min_frequency_hz: float, max_frequency_hz: float) -> None:
    """Refuse drive limits outside where the module's response is flat: above its AC
    coupling's -0.1 dB corner (if any channel is AC-coupled) and below 0.45 fs."""
    spec = module_spec(module)
    corner = spec.ac_flat_from_hz if any(c.coupling == "AC" for c in channels) else 0.0
    if min_frequency_hz < corner:
        raise ConfigError(f"{module} AC-coupled inputs are flat (within 0.1 dB) only above "
                          f"{corner:g} Hz; limits.min_frequency_hz is {min_frequency_hz:g} Hz "
                          "(raise it; static displacement is not measured on AC inputs)",
                          field="limits.min_frequency_hz")
    if max_frequency_hz > 0.45 * sample_rate_hz:
        raise ConfigError(f"{module} at {sample_rate_hz:g} S/s is flat up to "
                          f"{0.45 * sample_rate_hz:g} Hz (0.45 fs); limits.max_frequency_hz is "
                          f"{max_frequency_hz:g} Hz", field="limits.max_frequency_hz")
