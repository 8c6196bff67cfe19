"""Nanocomposite shear-sensor calibration against the reference force sensor (seed 002 III.B).

seed 002 calibrates the interfacial sensor against the Kistler reference: 301 N/V at
400 Hz, roughly constant over a band, different elsewhere. Here the factor (N/V) is
found per excitation frequency from the fundamental-frequency phasors of a steady
record, after removing the inertia the reference sensor also carries:

    the reference sensor sits in the drive link of beam 1, so
    F_ref = F_joint + m_1 a_1 (+ k_s x_1 + c_s v_1)
    ->   F_joint = F_ref + (m_1 omega^2 - k_s - i omega c_s) X_1

with X_1 the phasor of the beam-1 displacement channel (disp_1), m_1 the beam mass
between the sensor and the interface and, if the beam's support (suspension) is
known, its stiffness k_s and damping c_s (default 0). factor = |F_joint| / |V_nc|, signed by the
in-phase part; its standard uncertainty is the scatter over blocks of whole cycles
divided by sqrt(blocks). The phase by which F_joint leads V_nc is reported too, with its
standard uncertainty (the scatter of the per-block phases over sqrt(blocks)); runs
recorded after a calibration carry both, and the loop pipeline corrects the force for
that phase (see :mod:`labjoint.identify.loop`).

Calibrations live in a small JSON store (``<data_dir>/calibrations.json``):
per channel a list of points (frequency, N/V, uncertainty, source runs), and the
(frequency, N/V) table that :class:`labjoint.hardware.interfaces.ChannelSpec`'s
``calibration`` takes, so later runs apply it.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import asdict, dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage.roles import channel_roles

STORE_NAME = "calibrations.json"
STORE_VERSION = 1


def phasors(x: np.ndarray, sample_rate_hz: float, frequency_hz: float,
            n_blocks: int = 1) -> np.ndarray:
    """Complex amplitude of the ``frequency_hz`` component of each row of ``x``, per block.

    Least-squares fit of offset + cos + sin over each of ``n_blocks`` equal blocks of
    whole cycles (x(t) ~ Re(X e^{i omega t})). ``x`` (m, n) -> (m, n_blocks).
    """
    x = np.atleast_2d(np.asarray(x, float))
    period = sample_rate_hz / frequency_hz
    per_block = int(np.floor(x.shape[1] / n_blocks / period) * period)
    if per_block < period:
        raise InputError(f"record too short for {n_blocks} blocks of whole cycles",
                         field="n_blocks")
    t = np.arange(per_block) / sample_rate_hz
    w = 2 * np.pi * frequency_hz
    basis = np.stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)], axis=1)
    pinv = np.linalg.pinv(basis)                               # (3, per_block)
    out = np.empty((x.shape[0], n_blocks), complex)
    for b in range(n_blocks):
        start = int(round(b * x.shape[1] / n_blocks))
        # whole cycles from ``start``: phase of block b relative to t=0 of the record
        seg = x[:, start:start + per_block]
        coef = seg @ pinv.T                                    # (m, 3)
        ph = np.exp(-1j * w * start / sample_rate_hz)
        out[:, b] = (coef[:, 1] - 1j * coef[:, 2]) * ph
    return out


@dataclass(frozen=True)
class CalibrationPoint:
    """One calibration: sensor factor at a frequency, with uncertainty and provenance."""

    frequency_hz: float
    n_per_v: float
    uncertainty: float
    phase_deg: float = 0.0
    runs: tuple[str, ...] = ()
    phase_uncertainty_deg: float = float("nan")
    method: str = "fundamental phasors, reference force minus beam-1 inertia"
    beam_mass_kg: float = 0.0
    n_blocks: int = 0
    created: str = ""

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["runs"] = list(self.runs)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "CalibrationPoint":
        try:
            d = dict(d)
            d["runs"] = tuple(d.get("runs", ()))
            known = {f for f in cls.__dataclass_fields__}
            return cls(**{k: v for k, v in d.items() if k in known})
        except TypeError as exc:
            raise InputError(f"bad calibration entry: {exc}", field="calibration") from None


def calibration_factor(sensor_volts: np.ndarray, reference_force_n: np.ndarray,
                       beam1_displacement_m: np.ndarray, sample_rate_hz: float,
                       frequency_hz: float, beam_mass_kg: float, *, n_blocks: int = 8,
                       support_stiffness_n_per_m: float = 0.0,
                       support_damping_ns_per_m: float = 0.0,
                       runs: tuple[str, ...] = ()) -> CalibrationPoint:
    """Sensor factor (N/V) at ``frequency_hz`` from a steady record (see module doc)."""
    if not (np.isfinite(beam_mass_kg) and beam_mass_kg >= 0):
        raise InputError(f"beam mass must be >= 0 kg, got {beam_mass_kg}", field="beam_mass_kg")
    if not (np.isfinite(frequency_hz) and frequency_hz > 0):
        raise InputError(f"frequency must be positive, got {frequency_hz}", field="frequency_hz")
    for name, val in (("support_stiffness_n_per_m", support_stiffness_n_per_m),
                      ("support_damping_ns_per_m", support_damping_ns_per_m)):
        if not (np.isfinite(val) and val >= 0):
            raise InputError(f"must be finite and >= 0, got {val}", field=name)
    v = np.asarray(sensor_volts, float)
    if not (v.shape == np.shape(reference_force_n) == np.shape(beam1_displacement_m)):
        raise InputError("sensor, reference force and disp_1 need the same length",
                         field="sensor_volts")
    ph = phasors(np.stack([v, reference_force_n, beam1_displacement_m]), sample_rate_hz,
                 frequency_hz, n_blocks)
    vp, fref, x1 = ph
    if np.any(np.abs(vp) == 0):
        raise InputError("sensor channel carries no signal at the excitation frequency",
                         field="sensor_volts")
    omega = 2 * np.pi * frequency_hz
    # F_ref - m a_1 - k_s x_1 - c_s v_1 with a_1 = -w^2 X_1, v_1 = i w X_1
    dyn = beam_mass_kg * omega ** 2 - support_stiffness_n_per_m - 1j * omega * support_damping_ns_per_m
    f_joint = fref + dyn * x1
    ratio = f_joint / vp
    k = np.abs(ratio) * np.sign(ratio.real)
    mean = float(np.mean(k))
    sem = float(np.std(k, ddof=1) / np.sqrt(k.size)) if k.size > 1 else float("nan")
    phase = float(np.degrees(np.angle(np.mean(ratio) * np.sign(mean))))
    spread = np.angle(ratio / np.mean(ratio))          # per-block phase about the mean
    u_phase = float(np.degrees(np.std(spread, ddof=1) / np.sqrt(spread.size))) \
        if spread.size > 1 else float("nan")
    return CalibrationPoint(float(frequency_hz), mean, sem, phase, tuple(runs), u_phase,
                            beam_mass_kg=float(beam_mass_kg), n_blocks=int(k.size),
                            created=datetime.now(timezone.utc).isoformat(timespec="seconds"))


@dataclass
class CalibrationStore:
    """Calibration tables per channel, kept in one JSON file (atomic writes)."""

    path: Path
    channels: dict[str, list[CalibrationPoint]] = field(default_factory=dict)

    @classmethod
    def open(cls, path_or_dir: str | Path) -> "CalibrationStore":
        """Load the store at a file path, or ``<dir>/calibrations.json`` (empty if absent)."""
        p = Path(path_or_dir)
        if p.is_dir() or p.suffix != ".json":
            p = p / STORE_NAME
        store = cls(p)
        if not p.exists():
            return store
        try:
            data = json.loads(p.read_text())
            chans = data["channels"]
            for name, entry in chans.items():
                store.channels[name] = [CalibrationPoint.from_dict(d) for d in entry["points"]]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(f"unreadable calibration store: {exc}", file=str(p)) from None
        return store

    def add(self, channel: str, point: CalibrationPoint, tolerance_hz: float = 1e-6) -> None:
        """Add a point; one at the same frequency (within ``tolerance_hz``) is replaced."""
        pts = [q for q in self.channels.get(channel, [])
               if abs(q.frequency_hz - point.frequency_hz) > tolerance_hz]
        pts.append(point)
        self.channels[channel] = sorted(pts, key=lambda q: q.frequency_hz)

    def table(self, channel: str) -> tuple[tuple[float, float], ...]:
        """(frequency_hz, N/V) pairs for ``ChannelSpec.calibration``."""
        return tuple((q.frequency_hz, q.n_per_v) for q in self.channels.get(channel, []))

    def factor(self, channel: str, frequency_hz: float) -> float | None:
        """Interpolated factor at ``frequency_hz`` (None if the channel has no points)."""
        tab = self.table(channel)
        if not tab:
            return None
        f, k = np.array(tab).T
        return float(np.interp(frequency_hz, f, k))

    def phase_table(self, channel: str) -> tuple[tuple[float, float, float], ...]:
        """(frequency_hz, phase_deg, uncertainty_deg) for ``ChannelSpec.calibration_phase``;
        points without a phase uncertainty (older stores) are left out."""
        return tuple((q.frequency_hz, q.phase_deg, q.phase_uncertainty_deg)
                     for q in self.channels.get(channel, [])
                     if np.isfinite(q.phase_deg) and np.isfinite(q.phase_uncertainty_deg))

    def apply(self, specs: list[ChannelSpec]) -> list[ChannelSpec]:
        """Copies of ``specs`` with ``calibration`` (and ``calibration_phase``) filled for
        every calibrated channel."""
        return [replace(s, calibration=self.table(s.name),
                        calibration_phase=self.phase_table(s.name)) if self.table(s.name) else s
                for s in specs]

    def to_dict(self) -> dict[str, Any]:
        return {"version": STORE_VERSION,
                "channels": {name: {"table": [list(p) for p in self.table(name)],
                                    "points": [q.to_dict() for q in pts]}
                             for name, pts in sorted(self.channels.items())}}

    def save(self) -> Path:
        """Write the store atomically (temp file + rename); returns its path."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", dir=self.path.parent)
        try:
            with os.fdopen(fd, "w") as fh:
                json.dump(self.to_dict(), fh, indent=1)
            os.replace(tmp, self.path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
        return self.path


#: Run-metadata keys read when the caller does not give the beam-1 dynamics.
MASS_KEY = "beam_mass_kg"
SUPPORT_KEYS = ("beam_support_stiffness_n_per_m", "beam_support_damping_ns_per_m")
CLIP_FRACTION = 0.999


def calibrate_run(path: str | Path, *, beam_mass_kg: float | None = None,
                  support_stiffness_n_per_m: float | None = None,
                  support_damping_ns_per_m: float | None = None,
                  channel: str | None = None, n_blocks: int = 8) -> CalibrationPoint:
    """Calibrate the joint-force sensor of a run file against its reference force sensor.

    Uses raw volts of the sensor (never the factor the file already applies), the
    reference force (N) and disp_1 (m) over the steady cycles. The beam-1 mass comes
    from ``beam_mass_kg`` or the run metadata ``beam_mass_kg`` (required: without it
    the inertia of the beam would be calibrated into the factor). A clipped channel
    is refused.
    """
    from labjoint.storage import open_run          # storage is below identify
    with open_run(path) as rf:
        md = rf.metadata
        roles = channel_roles(md, rf.channel_names)
        sensor = channel or roles.joint_force
        ref, disp1 = roles.reference_force, roles.displacement[0]
        mass = beam_mass_kg if beam_mass_kg is not None else md.get(MASS_KEY)
        if mass is None:
            raise InputError("beam-1 mass between the reference sensor and the joint is "
                             "needed to remove its inertia (give it or store it in the run "
                             "metadata)", file=str(path), field="beam_mass_kg")
        k_s = support_stiffness_n_per_m if support_stiffness_n_per_m is not None \
            else float(md.get(SUPPORT_KEYS[0], 0.0))
        c_s = support_damping_ns_per_m if support_damping_ns_per_m is not None \
            else float(md.get(SUPPORT_KEYS[1], 0.0))
        volts = {name: rf.volts(name) for name in (sensor, ref, disp1)}
        for name, v in volts.items():
            rng = rf.channel(name).range_v
            if v.size and np.max(np.abs(v)) >= CLIP_FRACTION * rng and rf.channel(name).sensor != "imported":
                raise InputError(f"channel is clipped (|V| reached the {rng:g} V range); "
                                 "calibrate at a lower amplitude", file=str(path), field=name)
        fref, x1 = rf.physical(ref), rf.physical(disp1)
        fs, f, name = rf.sample_rate_hz, rf.frequency_hz, rf.name
    if f is None:
        from labjoint.signal.frequency import estimate_frequency
        f = estimate_frequency(x1, fs, min_hz=3.0 * fs / x1.size)
    from labjoint.identify.friction import steady_span
    span = steady_span(x1 - x1.mean(), fs, f)
    return calibration_factor(volts[sensor][span], fref[span], x1[span], fs, f, float(mass),
                              n_blocks=n_blocks, support_stiffness_n_per_m=k_s,
                              support_damping_ns_per_m=c_s, runs=(name,))


def calibrate_runs(paths: list[str | Path], store: CalibrationStore, *, channel: str | None = None,
                   write_processed: bool = True, **kwargs: Any) -> list[CalibrationPoint]:
    """Calibrate each run, add the points to ``store`` (saved), and record each in its run
    file's ``processed/calibration`` group."""
    from labjoint.storage import open_run, write_processed as _write
    points = []
    for p in paths:
        point = calibrate_run(p, channel=channel, **kwargs)
        with open_run(p) as rf:
            sensor = channel or channel_roles(rf.metadata, rf.channel_names).joint_force
        store.add(sensor, point)
        points.append(point)
        if write_processed:
            _write(p, "calibration", {"frequency": np.array(point.frequency_hz),
                                      "factor": np.array(point.n_per_v),
                                      "factor_uncertainty": np.array(point.uncertainty)},
                   attrs={"channel": sensor, **point.to_dict()},
                   units={"frequency": "Hz", "factor": "N/V", "factor_uncertainty": "N/V"})
    store.save()
    return points
