"""The rig factory: instruments chosen by the config alone.

``rig.backend = "sim"``: the physics simulator (the only import of
:mod:`labjoint.hardware.sim` outside that package, allowed by the import contract),
driven through the real AFG1022 driver on pyvisa-sim when ``generator.visa_library``
ends with ``@sim`` (the same driver code path as the lab), else through the simulator's
in-memory generator. ``rig.backend = "real"``: the AFG1022 over VISA and the NI DAQ.
Every backend starts with the generator output OFF.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from labjoint.acquisition.engine import RunEngine
from labjoint.acquisition.gate import TorqueGate
from labjoint.config import CONFIG_DIR, RigConfig
from labjoint.hardware.interfaces import DAQ, SignalGenerator

log = logging.getLogger(__name__)


@dataclass
class Rig:
    """Opened instruments; ``sim`` is the simulated rig's handle (``set_torque``,
    ``true_state``...) on backend 'sim', None on a real rig."""

    config: RigConfig
    generator: SignalGenerator
    daq: DAQ
    sim: Any = None

    @property
    def backend(self) -> str:
        return self.config.rig.backend

    def engine(self, callbacks: Sequence[Callable[[str, Any], None]] = (),
               torque_gate: TorqueGate | None = None, **kwargs: Any) -> RunEngine:
        """A :class:`RunEngine` on this rig (limits, roles and block size from the config)."""
        return RunEngine(self.generator, self.daq, self.config.limits, callbacks,
                         torque_gate=torque_gate, rig=self.sim, config=self.config, **kwargs)

    def close(self) -> None:
        """Output OFF and release the generator, then the DAQ (each failure logged)."""
        for what, close in (("generator", self.generator.close), ("DAQ", self.daq.close)):
            try:
                close()
            except Exception as exc:
                log.error("closing the %s failed: %s", what, exc)

    def __enter__(self) -> "Rig":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _config_dir(config: RigConfig) -> Path:
    """Where relative instrument files resolve: beside the config file if the named file
    is there, else the repository's configs folder."""
    lib = config.generator.visa_library
    if config.source:
        here = Path(config.source).resolve().parent
        name = lib[: -len("@sim")] if lib.endswith("@sim") else lib
        if name and (here / name).is_file():
            return here
    return CONFIG_DIR


def open_rig(config: RigConfig) -> Rig:
    """Open the instruments ``config`` names; the caller closes the returned :class:`Rig`."""
    if config.rig.backend == "sim":
        rig = _open_sim(config)
    else:
        rig = _open_real(config)
    try:
        rig.generator.set_output(False)
    except BaseException:
        rig.close()
        raise
    return rig


def _open_sim(config: RigConfig) -> Rig:
    from labjoint.hardware.sim.devices import SimDAQ, open_sim

    generator, daq, sim = open_sim(config)
    if config.generator.visa_library.endswith("@sim"):
        from labjoint.hardware.afg1022 import AFG1022

        afg = AFG1022.from_config(config.generator, _config_dir(config))
        generator.close()
        generator, daq = afg, SimDAQ(sim, afg, realtime=daq.realtime)
    return Rig(config, generator, daq, sim)


def _open_real(config: RigConfig) -> Rig:
    from labjoint.hardware.afg1022 import AFG1022
    from labjoint.hardware.nidaq import NIDAQ, check_channels, check_drive_band

    d, lim = config.daq, config.limits  # refused before any instrument is touched
    check_channels(d.module, d.specs())
    check_drive_band(d.module, d.specs(), d.sample_rate_hz, lim.min_frequency_hz, lim.max_frequency_hz)
    generator = AFG1022.from_config(config.generator, _config_dir(config))
    try:
        daq = NIDAQ.from_config(config.daq)
        daq.configure(config.daq.specs(), config.daq.sample_rate_hz)
    except BaseException:
        generator.close()
        raise
    return Rig(config, generator, daq, None)
