"""Sensors and DAQ input stage: sensitivity, nanocomposite response, noise, coupling, ADC.

Per channel: volts = quantity / sensitivity (the nanocomposite instead through its own
frequency response H(f), 1/|H(400 Hz)| = 301 N/V), plus sensor noise; then the module's
input coupling (AC: first-order high-pass, NI 9233 -3 dB at 0.5 Hz; or DC), DAQ input
noise, quantisation to ``bits`` over +-range_v and clipping at the range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.hardware.sim.config import NanocompositeConfig, SensorsConfig
from labjoint.hardware.sim.modules import ModuleSpec


def _nc_zpk(cfg: NanocompositeConfig) -> tuple[np.ndarray, np.ndarray, float]:
    ws = 2 * np.pi * cfg.shelf_hz
    wr = 2 * np.pi * cfg.resonance_hz
    zeta = cfg.resonance_damping
    z = np.array([-cfg.shelf_ratio * ws])
    p = np.concatenate([[-ws], np.roots([1.0, 2 * zeta * wr, wr * wr])])
    k0 = wr * wr
    h = _eval(z, p, k0, 2 * np.pi * cfg.reference_hz)
    return z, p, k0 / (abs(h) * cfg.factor_n_per_v)


def _eval(z: np.ndarray, p: np.ndarray, k: float, w: np.ndarray | float) -> np.ndarray:
    s = 1j * np.asarray(w, dtype=float)
    return k * np.prod(s[..., None] - z, axis=-1) / np.prod(s[..., None] - p, axis=-1)


def nanocomposite_response(frequency_hz: np.ndarray | float, cfg: NanocompositeConfig | None = None) -> np.ndarray:
    """Complex V/N of the nanocomposite shear-force sensor at ``frequency_hz``."""
    z, p, k = _nc_zpk(cfg or NanocompositeConfig())
    return _eval(z, p, k, 2 * np.pi * np.asarray(frequency_hz, dtype=float))


def nanocomposite_true_factor(frequency_hz: np.ndarray | float, cfg: NanocompositeConfig | None = None) -> np.ndarray:
    """The sensor's true calibration factor (N/V) at ``frequency_hz``: 1 / |H(f)|.

    >>> round(float(nanocomposite_true_factor(400.0)), 6)
    301.0
    """
    return 1.0 / np.abs(nanocomposite_response(frequency_hz, cfg))


def nanocomposite_sos(dt: float, cfg: NanocompositeConfig) -> np.ndarray:
    """Second-order sections of H at step ``dt`` (bilinear, prewarped to be exact at reference_hz)."""
    z, p, k = _nc_zpk(cfg)
    wref = 2 * np.pi * cfg.reference_hz
    fs_warp = wref / (2.0 * np.tan(wref * dt / 2.0))
    zd, pd, kd = signal.bilinear_zpk(z, p, k, fs_warp)
    return signal.zpk2sos(zd, pd, kd)


def noise_rms_volts(ch: ChannelSpec, cfg: SensorsConfig) -> float:
    """Sensor noise at the sensor output, in volts rms."""
    if ch.sensor == "nanocomposite":
        return cfg.nanocomposite_noise_n / cfg.nanocomposite.factor_n_per_v
    if ch.sensor == "force":
        return cfg.force_noise_n / abs(ch.sensitivity)
    if ch.sensor == "capacitive":
        return cfg.displacement_noise_m / abs(ch.sensitivity)
    return cfg.voltage_noise_v / abs(ch.sensitivity)


@dataclass
class InputStage:
    """One channel's conditioning: noise generator, coupling filter state, ADC."""

    spec: ChannelSpec
    noise_v: float
    daq_noise_v: float
    rng: np.random.Generator
    daq_rng: np.random.Generator
    hp_b: np.ndarray | None
    hp_a: np.ndarray | None
    bits: int
    zi: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.hp_b is not None:
            self.zi = np.zeros(1)

    @property
    def step_v(self) -> float:
        """Quantisation step: 2 range / 2^bits."""
        return 2.0 * self.spec.range_v / 2.0**self.bits

    def convert(self, volts: np.ndarray) -> np.ndarray:
        """Noise, coupling, ADC noise, quantisation and clipping of the sensor output."""
        n = volts.shape[0]
        x = volts + self.noise_v * self.rng.standard_normal(n) if self.noise_v > 0 else volts.copy()
        if self.hp_b is not None:
            x, self.zi = signal.lfilter(self.hp_b, self.hp_a, x, zi=self.zi)
        if self.daq_noise_v > 0:
            x = x + self.daq_noise_v * self.daq_rng.standard_normal(n)
        step = self.step_v
        half = 2 ** (self.bits - 1)
        codes = np.clip(np.rint(x / step), -half, half - 1)
        return codes * step


def ac_coupling(cutoff_hz: float, sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order high-pass (bilinear, exact -3 dB at ``cutoff_hz``)."""
    kk = np.tan(np.pi * cutoff_hz / sample_rate_hz)
    b = np.array([1.0, -1.0]) / (1.0 + kk)
    a = np.array([1.0, (kk - 1.0) / (kk + 1.0)])
    return b, a


def make_stages(channels: list[ChannelSpec], sample_rate_hz: float, module: ModuleSpec,
                cfg: SensorsConfig, seeds: np.random.SeedSequence) -> list[InputStage]:
    """One input stage per channel, each with its own noise streams (block-size independent).

    Streams are spawned from ``seeds``, so every (re)configuration draws new, reproducible noise.
    """
    seqs = seeds.spawn(2 * len(channels))
    stages = []
    for i, ch in enumerate(channels):
        module.check_coupling(ch.name, ch.coupling)
        if not ch.range_v > 0:  # pragma: no cover - ChannelSpec checks it
            raise ConfigError("range must be positive", field=f"channels.{ch.name}.range_v")
        b, a = ac_coupling(module.ac_cutoff_hz, sample_rate_hz) if ch.coupling == "AC" else (None, None)
        stages.append(InputStage(spec=ch, noise_v=noise_rms_volts(ch, cfg), daq_noise_v=cfg.daq_noise_v,
                                 rng=np.random.default_rng(seqs[2 * i]),
                                 daq_rng=np.random.default_rng(seqs[2 * i + 1]), hp_b=b, hp_a=a, bits=module.bits))
    return stages
