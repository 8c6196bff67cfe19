"""The simulated rig: physics state, streaming advance, sensors; owned by :class:`SimDAQ`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings
from labjoint.hardware.sim import integrator as ig
from labjoint.hardware.sim.config import SimConfig
from labjoint.hardware.sim.contact import Rings, make_rings
from labjoint.hardware.sim.joint import INV_EW, LAYER_C, N_JOINT_STATE, pack_joint
from labjoint.hardware.sim.sensors import InputStage, make_stages, nanocomposite_sos

#: Channel names the simulator recognises without a role table.
DEFAULT_ROLES = {"force_ref": "force_ref", "force_ref_2": "force_ref_2", "disp_1": "disp_1",
                 "disp_2": "disp_2", "shear_nc": "joint_force", "drive": "drive_voltage"}
ROLE_QUANTITY = {"force_ref": "force", "force_ref_2": "force", "disp_1": "displacement",
                 "disp_2": "displacement", "joint_force": "force", "drive_voltage": "voltage"}
ROLE_ROW = {"force_ref": ig.FL1M, "force_ref_2": ig.FL2M, "disp_1": ig.X1M, "disp_2": ig.X2M,
            "joint_force": ig.FSM, "drive_voltage": ig.DRIVE}
CHUNK = 1 << 16
_NO_WAVE = np.zeros(0)


@dataclass(frozen=True)
class TrueState:
    """Noise-free physics of the last :meth:`SimRig.advance` block (SI units).

    ``joint_force`` is the tangential force the joint carries (with any preload F0);
    ``sensed`` maps each channel to the quantity at its sensor's input (after inertia
    and channel delay, before sensor response, noise, coupling and ADC).
    """

    time_s: np.ndarray
    x1: np.ndarray
    x2: np.ndarray
    joint_force: np.ndarray
    dissipated_energy_j: np.ndarray
    drive_v: np.ndarray
    sensed: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def u(self) -> np.ndarray:
        """Relative displacement x1 - x2 (m), positive with the joint force."""
        return self.x1 - self.x2


class SimRig:
    """Two beams in a bolted lap joint, shaken in antiphase, read by a simulated DAQ module.

    ``advance(n, settings)`` continues from the current state (started from rest) and
    returns volts shaped (n_channels, n) in the order of ``channels``.
    """

    def __init__(self, sim_config: SimConfig, channels: list[ChannelSpec], sample_rate_hz: float) -> None:
        self.config = sim_config
        self._spec = sim_config.joint_spec
        self._module = sim_config.module_spec
        self._torque = float(sim_config.contact.torque_nm)
        self._rings = self._make_rings() if self._spec.has_contact else None
        self._joint = pack_joint(self._spec, self._rings, sim_config.layer)
        d = sim_config.dynamics
        self._dyn = np.array([d.armature_mass_kg, d.suspension_stiffness_n_per_m, d.suspension_damping_ns_per_m,
                              d.link_stiffness_n_per_m, d.link_damping_ns_per_m, d.beam_masses_kg[0],
                              d.beam_masses_kg[1], d.support_stiffness_n_per_m, d.support_damping_ns_per_m])
        self._gk = d.amplifier_gain_a_per_v * d.force_constant_n_per_a
        self._truth: TrueState | None = None
        self._channels: list[ChannelSpec] = []
        self.reset()
        self.configure(channels, sample_rate_hz)

    # -- set-up ---------------------------------------------------------------------------
    def _make_rings(self) -> Rings:
        c = self.config.contact
        return make_rings(normal_force_n=self.normal_force_n, bolt_radius_m=c.bolt_radius_m,
                          friction_coefficient=c.friction_coefficient,
                          shear_stiffness_n_per_m=self.config.ring_stiffness_n_per_m, n_rings=c.rings,
                          contact_ratio=c.contact_ratio, edge_refinement=c.edge_refinement)

    def reset(self) -> None:
        """Back to rest: zero motion, unslipped rings, no wear, phase 0."""
        self._q = np.zeros(4)
        self._v = np.zeros(4)
        self._acc = np.zeros(4)
        self._st = np.zeros(1 + N_JOINT_STATE)
        self._joint.reset()
        self._time = 0.0
        self._samples = 0
        self._seeds = np.random.SeedSequence(self.config.seed)
        if self._channels:
            self.configure(self._channels, self._fs)

    def configure(self, channels: list[ChannelSpec], sample_rate_hz: float) -> float:
        """Set channels and rate (snapped to what the module offers); return the actual rate."""
        if not channels:
            raise ConfigError("at least one channel is needed", field="channels")
        fs = self._module.snap_rate(sample_rate_hz)
        roles = [self._role(ch) for ch in channels]
        n_sub = self.config.substeps or max(1, math.ceil(1.0 / (fs * self.config.max_step_s) - 1e-9))
        self._fs, self._n_sub, self._dt = fs, n_sub, 1.0 / (fs * n_sub)
        self._channels, self._roles = list(channels), roles
        self._check_stability()
        self._stages: list[InputStage] = make_stages(self._channels, fs, self._module, self.config.sensors,
                                                     self._seeds)
        self._nc_sos = nanocomposite_sos(self._dt, self.config.sensors.nanocomposite)
        self._nc_zi = np.zeros((self._nc_sos.shape[0], 2))
        tau = self._spec.tau
        self._delay_steps = abs(tau) / self._dt
        self._delay_group = 0 if tau == 0 else (1 if tau > 0 else 2)
        self._dbuf = np.zeros((ig.N_DELAY, int(self._delay_steps) + 3))
        self._dbuf[0], self._dbuf[1] = self._q[1], self._q[2]
        self._didx = np.zeros(1, dtype=np.int64)
        return fs

    def _check_stability(self) -> None:
        """The explicit scheme needs omega_max dt and (c/m) dt well below 2; refuse otherwise."""
        ma, ks, cs, kl, cl, m1, m2, kb, cb = self._dyn
        j = self._joint
        k_joint = float(np.sum(j.jk)) + abs(j.eff[0])
        for par in j.sm_par:
            k_joint += par[0]  # k0, E0 or ke: the initial stiffness of the smooth laws
        m = min(m1, m2)
        w2 = max((ks + kl) / ma, (kl + kb) / m + k_joint * (1 / m1 + 1 / m2))
        damp = max((cs + cl) / ma, (cl + cb) / m + (j.eff[2] + j.eff[LAYER_C]) * (1 / m1 + 1 / m2))
        if math.sqrt(w2) * self._dt > 0.5 or damp * self._dt > 0.5:
            raise ConfigError(f"integration step {self._dt:.3g} s is too coarse for the rig's stiffest mode "
                              f"({math.sqrt(w2) / (2 * math.pi):.0f} Hz) or damping; lower max_step_s or set substeps",
                              field="sim.max_step_s")

    def _role(self, ch: ChannelSpec) -> str:
        role = self.config.channel_roles.get(ch.name) or DEFAULT_ROLES.get(ch.name)
        if role is None:
            role = {"nanocomposite": "joint_force", "voltage": "drive_voltage"}.get(ch.sensor)
        if role is None:
            raise ConfigError(f"the simulator does not know what channel {ch.name!r} measures; name it in "
                              f"[sim.channel_roles] (one of {sorted(ROLE_QUANTITY)})", field=f"channels.{ch.name}")
        if ROLE_QUANTITY[role] != ch.quantity:
            raise ConfigError(f"channel measures {role} ({ROLE_QUANTITY[role]}) but is declared as {ch.quantity!r}",
                              field=f"channels.{ch.name}.quantity")
        return role

    # -- properties -----------------------------------------------------------------------
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
        """Simulated time since rest (s)."""
        return self._time

    @property
    def samples_advanced(self) -> int:
        return self._samples

    @property
    def torque_nm(self) -> float:
        return self._torque

    @property
    def normal_force_n(self) -> float:
        """Bolt normal force: torque x torque_to_normal (seed 002: 478 N/Nm)."""
        return self._torque * self.config.contact.torque_to_normal_n_per_nm

    @property
    def rings(self) -> Rings | None:
        """The contact rings at the current torque (None if another law replaces the contact)."""
        return self._rings

    @property
    def dissipated_energy_j(self) -> float:
        """Energy the joint's hysteretic elements have dissipated since rest (J)."""
        return float(self._st[2])

    @property
    def wear_factor(self) -> float:
        """Current slip-strength factor exp(-E_d / E_w) (1 without ``wear``)."""
        inv = self._joint.eff[INV_EW]
        return math.exp(-self.dissipated_energy_j * inv) if inv > 0 else 1.0

    def ring_state(self) -> dict[str, np.ndarray]:
        """Contact rings: radii, stiffness, slip force (N), slider position and force now."""
        if self._rings is None:
            raise ConfigError("the simulated joint has no contact rings", field="sim.joint")
        n = self._joint.n_contact
        u_eff = self._st[3] if self._spec.layer else self._st[1]   # the layer's far side y
        z = self._joint.jz[:n].copy()
        return {"r_in": self._rings.r_in, "r_out": self._rings.r_out, "stiffness": self._rings.stiffness,
                "slip_force": self._rings.slip_force, "slider": z, "force": self._rings.stiffness * (u_eff - z)}

    # -- operation ------------------------------------------------------------------------
    def set_torque(self, torque_nm: float) -> None:
        """New bolt torque: ring thresholds from the new normal force; motion and slip state kept."""
        t = float(torque_nm)
        if not (math.isfinite(t) and t > 0):
            raise ConfigError(f"torque must be positive, got {torque_nm!r} Nm", field="torque_nm")
        self._torque = t
        if self._rings is not None:
            self._rings = self._make_rings()
            self._joint.set_contact_slip_forces(self._rings.slip_force)

    def simulate(self, n_samples: int, settings: GeneratorSettings,
                 wave: np.ndarray | None = None) -> np.ndarray:
        """Advance the physics only; return the kernel's rows (see :mod:`.integrator`).

        ``settings.shape`` "user" plays ``wave`` (one period, peak 1) as the generator's
        arbitrary waveform does: each point held for 1 / (N f) (a staircase).
        """
        n = int(n_samples)
        if n < 0:
            raise ValueError("n_samples must be >= 0")
        if getattr(settings, "shape", "sine") == "user":
            if wave is None or np.asarray(wave).size < 2:
                raise ConfigError("the generator plays an arbitrary waveform but none was given",
                                  field="generator.waveform")
            table = np.ascontiguousarray(wave, dtype=float)
        else:
            table = _NO_WAVE
        f = float(settings.frequency_hz)
        on = bool(settings.output) and math.isfinite(f) and f > 0
        drive = np.array([0.5 * settings.amplitude_vpp, settings.offset_v, 2 * math.pi * f if on else 0.0,
                          1.0 if on else 0.0, self._gk, self.config.dynamics.shaker_balance])
        out = np.empty((ig.N_OUT, n))
        j = self._joint
        for a in range(0, n, CHUNK):
            b = min(n, a + CHUNK)
            buf = out if b - a == n else np.empty((ig.N_OUT, b - a))  # always C-contiguous: one compiled kernel
            ig.integrate(b - a, self._n_sub, self._dt, drive, table, self._dyn, self._q, self._v, self._acc, self._st,
                         j.jk, j.jphi, j.jz, j.sm_code, j.sm_par, j.sm_st, j.eff, self._dbuf, self._didx,
                         self._delay_steps, self._delay_group, self._nc_sos, self._nc_zi, buf)
            if buf is not out:
                out[:, a:b] = buf
        t0 = self._time
        self._time += n / self._fs
        self._samples += n
        self._truth = TrueState(
            time_s=t0 + np.arange(1, n + 1) / self._fs, x1=out[ig.X1], x2=out[ig.X2], joint_force=out[ig.FJ],
            dissipated_energy_j=out[ig.ED], drive_v=out[ig.DRIVE],
            sensed={ch.name: out[ROLE_ROW[r]] for ch, r in zip(self._channels, self._roles)})
        return out

    def advance(self, n_samples: int, settings: GeneratorSettings,
                wave: np.ndarray | None = None) -> np.ndarray:
        """Advance ``n_samples`` with the generator at ``settings`` (and its arbitrary
        waveform ``wave`` when it plays one); volts (n_channels, n)."""
        out = self.simulate(n_samples, settings, wave)
        volts = np.empty((len(self._channels), out.shape[1]))
        for i, (ch, role, stage) in enumerate(zip(self._channels, self._roles, self._stages)):
            if role == "joint_force" and ch.sensor == "nanocomposite":
                raw = out[ig.NCV]
            else:
                raw = out[ROLE_ROW[role]] / ch.sensitivity
            volts[i] = stage.convert(raw)
        return volts

    def true_state(self) -> TrueState:
        """Noise-free physics of the last advanced block."""
        if self._truth is None:
            raise RuntimeError("nothing simulated yet")
        return self._truth
