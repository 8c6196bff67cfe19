"""The simulated structural rig: seed 000's pipe assembly on a shaker, read by a DAQ module.

Same streaming interface as :class:`~labjoint.hardware.sim.rig.SimRig` (``configure``,
``advance``, ``channels``, ``sample_rate_hz``, ``true_state``), so :class:`SimDAQ` and the
run engine drive it unchanged. Channel roles: a channel named like an accelerometer
(``[sim.assembly.accelerometers]``) reads its acceleration; sensor ``force`` the stinger
force; sensor ``voltage`` the generator voltage (``amplifier_voltage`` by role).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings
from labjoint.hardware.sim import structure_kernel as sk
from labjoint.hardware.sim.modules import get_module
from labjoint.hardware.sim.sensors import InputStage, ac_coupling
from labjoint.hardware.sim.structure_config import SIGNAL_ROLES, StructureSimConfig
from labjoint.hardware.sim.structure_fe import Reduced, reduce
from labjoint.hardware.sim.structure_iwan import iwan_parameters, iwan_state

ROLE_QUANTITY = {"force": "force", "drive_voltage": "voltage", "amplifier_voltage": "voltage"}
ROLE_ROW = {"force": sk.FORCE, "drive_voltage": sk.V_GEN, "amplifier_voltage": sk.V_AMP}
CHUNK = 1 << 15


@dataclass(frozen=True)
class StructureTruth:
    """Noise-free physics of the last block (SI): generator voltage, coil current, stinger
    force, each thread's slip u (m) and tangential force (N), accelerations per sensor."""

    time_s: np.ndarray
    drive_v: np.ndarray
    current_a: np.ndarray
    force_n: np.ndarray
    slip_m: np.ndarray
    joint_force_n: np.ndarray
    acceleration: dict[str, np.ndarray]


def slip_displacements(chi: float, elements: int) -> np.ndarray:
    """Equal-weight Iwan elements whose slip displacements follow phi^chi on (0, 1].

    >>> slip_displacements(0.0, 2).tolist()
    [0.25, 0.75]
    """
    return ((np.arange(elements) + 0.5) / elements) ** (1.0 / (1.0 + chi))


class SimStructureRig:
    """Clamped-free pipe assembly with hysteretic threads, shaker, force sensor, accelerometers."""

    def __init__(self, config: StructureSimConfig, channels: list[ChannelSpec], sample_rate_hz: float) -> None:
        self.config = config
        self._module = get_module(config.module_name)
        j, sh = config.joint, config.shaker
        self.model: Reduced = reduce(config.assembly, sh, j.rotational_stiffness_nm_per_rad)
        kt = j.rotational_stiffness_nm_per_rad / j.radius_m**2
        n_j = self.model.joints.shape[0]
        hyst = 0.0 if j.law == "linear" else (1.0 - j.residual_fraction)
        continuous = j.law == "iwan" and j.elements == 0
        n_e = j.elements if j.law == "iwan" and not continuous else 1
        s = slip_displacements(0.0 if n_e == 1 else j.chi, n_e) * (2.0 if n_e == 1 else 1.0)
        k_el = hyst * kt / n_e
        # slip force of the hysteretic part = k_el * sum(phi_i) = slip_force_n
        phi = s * (j.slip_force_n / (k_el * s.sum()) if k_el > 0 else 1.0)
        self._k_stick = np.full(n_j, kt)
        self._k_res = np.full(n_j, kt - k_el * n_e)
        self._k_el = np.full(n_j, k_el)
        self._phi = np.tile(phi, (n_j, 1))
        self._c_t = np.full(n_j, j.viscous_ns_per_m)
        self._law = 1 if j.law == "richard_abbott" else 2 if continuous else 0
        self._iw = iwan_parameters(hyst * kt if hyst > 0 else 1.0, j.slip_force_n, j.chi)
        self._ra = np.tile([kt * (1 - j.residual_fraction), kt * j.residual_fraction, j.slip_force_n,
                            j.ra_exponent], (n_j, 1))
        self._c_modal = 2 * self.model.zeta * self.model.omega
        self._par_shaker = (sh.amplifier_gain_v_per_v, sh.coil_resistance_ohm, sh.coil_inductance_h,
                            sh.force_factor_n_per_a, sh.suspension_damping_ns_per_m,
                            sh.suspension_stiffness_n_per_m, sh.armature_mass_kg)
        self._truth: StructureTruth | None = None
        self._channels: list[ChannelSpec] = []
        self.reset()
        self.configure(channels, sample_rate_hz)

    def reset(self) -> None:
        """Back to rest: no motion, no current, sliders unslipped."""
        n = self.model.omega.size
        self._eta, self._etad, self._accp = np.zeros(n), np.zeros(n), np.zeros(n)
        self._z = np.zeros_like(self._phi)
        self._ras = np.zeros((self._phi.shape[0], sk.N_RA_STATE))
        self._ras[:, 6] = 1.0   # virgin: on the backbone
        self._ist, self._ihist = iwan_state(self._phi.shape[0])
        self._state = np.zeros(3)
        self._time, self._samples = 0.0, 0
        self._seeds = np.random.SeedSequence(self.config.seed)
        if self._channels:
            self.configure(self._channels, self._fs)

    def configure(self, channels: list[ChannelSpec], sample_rate_hz: float) -> float:
        """Set channels and rate (snapped to the module's); return the actual rate."""
        if not channels:
            raise ConfigError("at least one channel is needed", field="channels")
        fs = self._module.snap_rate(sample_rate_hz)
        rows = [self._row(ch) for ch in channels]
        n_sub = max(1, math.ceil(1.0 / (fs * self.config.max_step_s) - 1e-9))
        dt = 1.0 / (fs * n_sub)
        if self.model.omega[-1] * dt > 0.5:
            raise ConfigError(f"integration step {dt:.3g} s is too coarse for the highest kept mode "
                              f"({self.model.frequencies_hz[-1]:.0f} Hz); lower max_step_s",
                              field="sim.max_step_s")
        self._fs, self._n_sub, self._dt = fs, n_sub, dt
        self._channels, self._rows = list(channels), rows
        seqs = self._seeds.spawn(2 * len(channels))
        sn = self.config.sensors
        self._stages = []
        for i, ch in enumerate(channels):
            self._module.check_coupling(ch.name, ch.coupling)
            noise = {"force": sn.force_noise_n, "acceleration": sn.acceleration_noise_m_s2,
                     "voltage": sn.voltage_noise_v}[ch.quantity] / abs(ch.sensitivity)
            b, a = ac_coupling(self._module.ac_cutoff_hz, fs) if ch.coupling == "AC" else (None, None)
            self._stages.append(InputStage(ch, noise, sn.daq_noise_v, np.random.default_rng(seqs[2 * i]),
                                           np.random.default_rng(seqs[2 * i + 1]), b, a, self._module.bits))
        return fs

    def _row(self, ch: ChannelSpec) -> int:
        role = self.config.channel_roles.get(ch.name)
        names = self.model.sensor_names
        if role is None:
            role = ch.name if ch.name in names else {"force": "force", "voltage": "drive_voltage"}.get(ch.sensor)
        if role is None or (role not in names and role not in SIGNAL_ROLES):
            raise ConfigError(f"the structural simulator does not know what channel {ch.name!r} measures; "
                              f"name it like an accelerometer {list(names)} or give it a role in "
                              f"[sim.channel_roles] (one of {list(SIGNAL_ROLES)})", field=f"channels.{ch.name}")
        quantity = "acceleration" if role in names else ROLE_QUANTITY[role]
        if quantity != ch.quantity:
            raise ConfigError(f"channel measures {role} ({quantity}) but is declared as {ch.quantity!r}",
                              field=f"channels.{ch.name}.quantity")
        return sk.ACC + names.index(role) if role in names else ROLE_ROW[role]

    @property
    def channels(self) -> list[ChannelSpec]:
        return list(self._channels)

    @property
    def sample_rate_hz(self) -> float:
        return self._fs

    @property
    def substeps(self) -> int:
        return self._n_sub

    @property
    def time_s(self) -> float:
        return self._time

    def simulate(self, n_samples: int, settings: GeneratorSettings) -> np.ndarray:
        """Advance the physics only; the kernel's rows (:mod:`.structure_kernel`)."""
        n = int(n_samples)
        if n < 0:
            raise ValueError("n_samples must be >= 0")
        if getattr(settings, "shape", "sine") != "sine":
            raise ConfigError("the structural simulator plays sines only", field="generator.waveform")
        f = float(settings.frequency_hz)
        on = bool(settings.output) and math.isfinite(f) and f > 0
        par = np.array([0.5 * settings.amplitude_vpp, settings.offset_v, 2 * math.pi * f if on else 0.0,
                        1.0 if on else 0.0, *self._par_shaker])
        m = self.model
        out = np.empty((sk.ACC + len(m.sensor_names), n))
        for a in range(0, n, CHUNK):
            b = min(n, a + CHUNK)
            buf = np.empty((out.shape[0], b - a))
            sk.integrate(b - a, self._n_sub, self._dt, par, m.omega, self._c_modal, m.drive, m.sensors,
                         m.joints, self.config.joint.radius_m, self._k_stick, self._k_res, self._k_el,
                         self._phi, self._c_t, self._eta, self._etad, self._accp, self._z, self._state, buf,
                         self._law, self._ra, self._ras, self._iw, self._ist, self._ihist)
            out[:, a:b] = buf
        t0 = self._time
        self._time += n / self._fs
        self._samples += n
        self._truth = StructureTruth(
            time_s=t0 + np.arange(1, n + 1) / self._fs, drive_v=out[sk.V_GEN], current_a=out[sk.CURRENT],
            force_n=out[sk.FORCE], slip_m=out[[sk.U0, sk.U1]], joint_force_n=out[[sk.F0, sk.F1]],
            acceleration={s: out[sk.ACC + i] for i, s in enumerate(m.sensor_names)})
        return out

    def advance(self, n_samples: int, settings: GeneratorSettings, wave: np.ndarray | None = None) -> np.ndarray:
        """Volts (n_channels, n) after ``n_samples`` more samples at ``settings``."""
        out = self.simulate(n_samples, settings)
        volts = np.empty((len(self._channels), out.shape[1]))
        for i, (ch, row, stage) in enumerate(zip(self._channels, self._rows, self._stages)):
            volts[i] = stage.convert(out[row] / ch.sensitivity)
        return volts

    def true_state(self) -> StructureTruth:
        """Noise-free physics of the last advanced block."""
        if self._truth is None:
            raise RuntimeError("nothing simulated yet")
        return self._truth
