"""What the simulated DAQ module offers: sample-rate ladder, coupling, ADC, range."""

from __future__ import annotations

from dataclasses import dataclass

from labjoint.errors import ConfigError


@dataclass(frozen=True)
class ModuleSpec:
    """A C-series sound-and-vibration module: rates ``base_rate_hz / n``, n = 1..max_divisor."""

    name: str
    base_rate_hz: float
    max_divisor: int
    couplings: tuple[str, ...]
    ac_cutoff_hz: float = 0.5
    bits: int = 24

    def rates(self) -> list[float]:
        """Every rate the module offers, highest first."""
        return [self.base_rate_hz / n for n in range(1, self.max_divisor + 1)]

    def snap_rate(self, requested_hz: float) -> float:
        """The rate the module runs at for ``requested_hz``: the next offered rate >= requested.

        >>> MODULES["NI 9233"].snap_rate(20000.0)
        25000.0
        >>> MODULES["NI 9233"].snap_rate(50000.0)
        50000.0
        """
        lo, hi = self.base_rate_hz / self.max_divisor, self.base_rate_hz
        r = float(requested_hz)
        if not (lo * (1 - 1e-9) <= r <= hi * (1 + 1e-9)):
            raise ConfigError(f"{self.name} offers {lo:g}..{hi:g} S/s ({hi:g}/n, n = 1..{self.max_divisor}); "
                              f"requested {requested_hz!r}", field="sample_rate_hz")
        n = int(self.base_rate_hz / r * (1 + 1e-9))
        return self.base_rate_hz / max(1, min(n, self.max_divisor))

    def check_coupling(self, channel: str, coupling: str) -> None:
        if coupling not in self.couplings:
            raise ConfigError(f"{self.name} supports {'/'.join(self.couplings)} coupling only, "
                              f"channel asks for {coupling!r}", field=f"channels.{channel}.coupling")


#: Modules the simulator knows (NI data sheets): NI 9233 is AC-coupled only (-3 dB at 0.5 Hz).
MODULES: dict[str, ModuleSpec] = {
    m.name: m
    for m in (
        ModuleSpec("NI 9233", 50000.0, 25, ("AC",)),
        ModuleSpec("NI 9234", 51200.0, 31, ("AC", "DC")),
    )
}


def get_module(name: str) -> ModuleSpec:
    try:
        return MODULES[name]
    except KeyError:
        raise ConfigError(f"unknown DAQ module {name!r} for the simulator; known: {sorted(MODULES)}",
                          field="daq.module") from None
