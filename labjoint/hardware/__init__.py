"""Instrument interfaces and their backends (real driver, physics simulator).

Backends are chosen by config through :func:`labjoint.acquisition.rig.open_rig`;
nothing outside the factory imports :mod:`labjoint.hardware.sim`.
"""

from labjoint.hardware.interfaces import DAQ, ChannelSpec, GeneratorSettings, SignalGenerator

__all__ = ["DAQ", "ChannelSpec", "GeneratorSettings", "SignalGenerator"]
