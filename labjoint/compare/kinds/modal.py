"""The ``modal`` kind: records of a structure nobody can describe, judged on its measured
responses (issue 29 items 2 and 5).

Measurement (:class:`ModalMeasurement`, made by :func:`.modal_prepare.prepare_modal`): one
record (a steady sine test, a random or burst test) with a voltage or force drive and
motion responses, each in its measured quantity,
and the modal model of :mod:`labjoint.structure.nlmode` (measured modes, the joint on
mode 1) as predictor. A steady sine (a ``frequency_hz`` in the metadata; the drive's own
frequency, estimated from its samples, is the one used) is simulated over the last
``warmup + judge`` seconds before its drive stops from the linear steady state of its fundamental
and judged on whole periods of the last ``judge`` seconds; any other record is
simulated from rest at its first sample (a burst or random test that starts at rest)
and judged whole.

Residual: per response channel, model minus measured over the channel's rms on its
judged samples (the measured channel's mean removed), so every channel and every record
counts alike; the core's "measured force" is these normalized samples, channel after
channel. Its NRMSE is rms(residual) / rms(measured), pooled.
Units (the paired test): 16 blocks of the judged samples per channel.
Noise floor (stated): per channel the difference method of
:func:`labjoint.compare.noise.difference_variance` on its judged samples (consistent
for white noise on a signal smooth on the sample scale; an upper bound where the signal
holds power near Nyquist), pooled over channels.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from labjoint.compare.measurement import RunNoise
from labjoint.compare.noise import difference_variance
from labjoint.errors import InputError
from labjoint.models import Model, Parameters, RunData
from labjoint.structure.nlmode import (QUANTITY_ORDER, Drive, MeasuredMode, ModalBasis, lead,
                                       linear_states, mode_states, response)
from labjoint.structure.nlmode_pair import pair_response, pair_states, relative_displacement

METHOD = ("per response channel the difference method on its judged samples (rms-normalized), "
          "pooled over channels")
WARMUP_S = 4.0
JUDGE_S = 1.0
BLOCKS = 16
END_MARGIN_S = 0.5


@dataclass(frozen=True)
class ModalSetup:
    """What the user sets for every fit of a modal set: ``start`` {name: value} (SI; a fit
    from a smaller model keeps that model's values), ``bounds`` {name: (lo, hi)} and the
    shaker path (:class:`labjoint.structure.nlmode_shaker.ShakerPath`, None: a voltage or
    force drive with a fitted high-pass only)."""

    start: tuple[tuple[str, float], ...] = ()
    bounds: tuple[tuple[str, tuple[float, float]], ...] = ()
    shaker: Any = None
    #: fit the joint's participation in modes 2..N (``modal.joint<j>``) instead of taking it
    #: from the two sensors' shapes (:mod:`labjoint.structure.nlmode_pair`)
    joint_shape: bool = False

    @property
    def start_dict(self) -> dict[str, float]:
        return dict(self.start)

    @property
    def bounds_dict(self) -> dict[str, tuple[float, float]]:
        return dict(self.bounds)


@dataclass(frozen=True, eq=False)
class ModalMeasurement:
    """One record inside the modal model (module docstring)."""

    kind: ClassVar[str] = "modal"
    noise_method: ClassVar[str] = METHOD
    name: str
    basis: ModalBasis
    drive: Drive
    channels: tuple[str, ...]
    quantities: tuple[str, ...]
    judged: slice
    scales: np.ndarray
    lin: tuple[np.ndarray, ...]
    data: RunData
    spans: np.ndarray
    level: float | None = None
    path: str | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    _cache: dict = field(default_factory=dict, repr=False)
    #: the joint between these two sensors (:mod:`labjoint.structure.nlmode_pair`), else on mode 1
    between: tuple[str, str] | None = None
    #: the user's fit setup (``start``, ``bounds``, the shaker): :class:`ModalSetup`
    setup: ModalSetup = field(default_factory=lambda: ModalSetup())

    @property
    def frequency_hz(self) -> float | None:
        return self.drive.frequency_hz

    def units(self) -> np.ndarray:
        return self.spans

    def axes(self) -> dict[str, Any]:
        return {"frequency_hz": self.frequency_hz, "level": self.level,
                "judged_s": (self.judged.stop - self.judged.start) / self.drive.fs}

    def drive_at(self, vals: Mapping[str, Any]) -> Drive:
        """The drive through the shaker path's high-pass (``shaker.highpass_hz``) and lag
        (``shaker.lag_s``; nlmode eqs. 4, 4b; each none if absent)."""
        fc, tau = path_filters(vals)
        if fc <= 0 and tau <= 0:
            return self.drive
        key = ("drive", fc, tau)
        if key not in self._cache:
            self._trim()
            self._cache[key] = self.drive.highpassed(fc).lagged(tau)
        return self._cache[key]

    def _trim(self) -> None:
        if len(self._cache) > 64:
            self._cache.clear()

    def states(self, model: Model, params: Parameters | dict) -> np.ndarray:
        """Mode 1's (n, 3) states, or every mode's (n, N, 3) with a two-point joint."""
        vals = {k: float(v.value if hasattr(v, "value") else v) for k, v in params.items()}
        path = self.setup.shaker
        if self.between:
            if path is not None:        # the shaker drives every mode at its drive point (nlmode_shaker P1)
                if self.metadata.get("drive_quantity") == "force":
                    raise InputError("a joint between two points through the shaker is per volt: its "
                                     "measured modes hold the shaker, so a force record is not "
                                     "predicted per newton", file=self.path, field="shaker")
                path.check_pair_coil(vals, max(m.frequency_hz for m in self.basis.modes))
                vals = {**vals, **path.pair_drives(vals, self.basis)}
            return pair_states(model, vals, self.basis, self.between, self.drive_at(vals))
        if path is not None and self.metadata.get("drive_quantity") == "force":
            # per newton: the structure alone (nlmode_shaker H1), driven by the measured force
            _, m_d = path.shaker(vals)
            q = mode_states(model, {**vals, "modal.drive": 1.0 / (path.phi_d * m_d)}, self.drive)
            return np.column_stack([q, self.drive.fine[::2 * self.drive.substeps][:q.shape[0]]])
        if path is not None:       # (n, 4): the force on the structure beside
            return path.states(model, vals, self.drive_at(vals), self.basis.modes[0].frequency_hz)
        return mode_states(model, vals, self.drive_at(vals))

    def structure_force(self, q: np.ndarray, vals: Mapping[str, Any]) -> np.ndarray:
        """With the shaker: the force on the structure at the drive point at every sample (N;
        nlmode_shaker H2 on mode 1, P2 with a two-point joint) from :meth:`states`' ``q``."""
        if self.between:
            v = {k: float(getattr(x, "value", x)) for k, x in vals.items()}
            return self.setup.shaker.pair_force(v, q, self.drive_at(v), self.basis)
        return q[:, 3]

    def other_drive(self, vals: Mapping[str, Any], q: np.ndarray | None) -> tuple[Drive, Any]:
        """What drives the linear modes and the residual terms, and its cache tag: the
        (high-passed) voltage; with the shaker, the force on the structure (the states'
        4th column: the model's H2 on a voltage record, the measured force on a force
        record), so their participations are per newton."""
        if self.setup.shaker is None:
            return self.drive_at(vals), path_filters(vals)
        if self.metadata.get("drive_quantity") == "force":
            return self.drive, "force"
        if q is None or q.ndim != 2 or q.shape[1] < 4:
            raise InputError("the shaker path needs mode 1's states to drive the other modes", field="shaker")
        F = np.ascontiguousarray(q[:, 3])
        tag = ("F", hash(F.tobytes()))
        if tag not in self._cache:
            self._trim()
            self._cache[tag] = Drive.of(F, self.drive.fs, self.frequency_hz,
                                        max(m.frequency_hz for m in self.basis.modes))
        return self._cache[tag], tag

    def plain_states(self, model: Model, vals: Mapping[str, float]) -> np.ndarray:
        """Mode 1's states driven by ``modal.drive`` x the (high-passed) voltage, no shaker."""
        return mode_states(model, vals, self.drive_at(vals))

    def linear(self, vals: Mapping[str, float], q: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """The linear modes' unit-gain states at ``modal.f<j>``, ``modal.zeta<j>`` when given
        (fitted), else at the measured ones, under :meth:`other_drive` (``q``: mode 1's states)."""
        out = []
        drive, fc = self.other_drive(vals, q)
        for j, mode in enumerate(self.basis.linear):
            f = float(vals.get(f"modal.f{j + 2}", mode.frequency_hz))
            z = float(vals.get(f"modal.zeta{j + 2}", mode.damping_ratio))
            if (j, f, z, fc) not in self._cache:
                self._trim()
                self._cache[(j, f, z, fc)] = linear_states(MeasuredMode(f, z, mode.shape), drive)
            out.append(self._cache[(j, f, z, fc)])
        return tuple(out)

    def residual_input(self, quantity: str, vals: Mapping[str, Any] | None = None,
                       q: np.ndarray | None = None) -> np.ndarray:
        """The (high-passed) drive's derivative of the sensor's order (V, dV/dt, d2V/dt2) at
        the segment's samples: the out-of-band modes' quasi-static response per unit
        ``modal.r.<s>`` (a residual flexibility; the measured drive is differentiated,
        never a response)."""
        dr, tag = self.other_drive(vals or {}, q)
        key = ("residual", quantity, tag)
        if key not in self._cache:
            self._trim()
            d = QUANTITY_ORDER[quantity]
            x, dt = dr.fine, 1.0 / (dr.fs * 2 * dr.substeps)
            for _ in range(d):
                x = np.gradient(x, dt)
            self._cache[key] = x[::2 * dr.substeps][:dr.n]
        return self._cache[key]

    def displacement_amplitude(self, model: Model, params: Parameters | dict) -> float:
        """The largest |q| on the judged samples (m at the reference sensor, mode 1)."""
        q = self.states(model, {k: float(v.value if hasattr(v, "value") else v) for k, v in params.items()})
        if self.between:
            return float(np.nanmax(np.abs(relative_displacement(q[self.judged], self.basis, self.between,
                                                                     params))))
        return float(np.nanmax(np.abs(q[self.judged, 0])))

    def responses(self, model: Model, params: Parameters | dict,
                  q: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The model's reading of every channel over the segment (SI, its quantity)."""
        vals = {k: float(v.value if hasattr(v, "value") else v) for k, v in params.items()}
        q = self.states(model, vals) if q is None else q
        out, quad = {}, {}        # quad: the quadrature parts per quantity, computed once
        if self.between:           # the measured shapes read every mode (nlmode_pair)
            return {ch: pair_response(q, self.basis, ch, qty, self.drive.fs)
                    for ch, qty in zip(self.channels, self.quantities)}
        for ch, qty in zip(self.channels, self.quantities):
            phi = 1.0 if ch == self.basis.reference else vals[f"modal.phi1.{ch}"]
            gains = [vals[f"modal.g{j + 2}.{ch}"] for j in range(len(self.lin))]
            out[ch] = response(q, self.linear(vals, q), qty, phi, gains) \
                + vals.get(f"modal.r.{ch}", 0.0) * self.residual_input(qty, vals, q)
            hs = self.quadrature_gains(ch, vals)
            if any(hs):
                if qty not in quad:
                    quad[qty] = self.quadrature(qty, vals, q)
                out[ch] = out[ch] + sum(h * c for h, c in zip(hs, quad[qty]))
        return out

    def quadrature(self, quantity: str, vals: Mapping[str, Any], q: np.ndarray) -> list[np.ndarray]:
        """Mode 1's and every linear mode's quadrature part at a sensor of ``quantity``
        (nlmode eq. 3b), in the order of :meth:`quadrature_gains`."""
        d, fs = QUANTITY_ORDER[quantity], self.drive.fs
        w = [2 * np.pi * float(vals.get(f"modal.f{j + 2}", m.frequency_hz))
             for j, m in enumerate(self.basis.linear)]
        return [lead(q, d, 2 * np.pi * self.basis.modes[0].frequency_hz, fs),
                *(lead(p, d, wj, fs) for p, wj in zip(self.linear(vals, q), w))]

    def quadrature_gains(self, ch: str, vals: Mapping[str, Any]) -> list[float]:
        """``modal.h<j>.<ch>`` of every mode (0 where absent: real modes)."""
        return [float(vals.get(f"modal.h{j + 1}.{ch}", 0.0)) for j in range(len(self.lin) + 1)]

    def normalized(self, series: dict[str, np.ndarray]) -> np.ndarray:
        j = self.judged
        return np.concatenate([(series[ch][j] - series[ch][j].mean()) / s
                               for ch, s in zip(self.channels, self.scales)])

    def predict(self, model: Model, params: Parameters | dict) -> np.ndarray:
        """The model's normalized responses on the judged samples (the core's model force)."""
        return self.normalized(self.responses(model, params))

    def figures(self, model_force: np.ndarray) -> dict[str, float]:
        """rms of the first channel's normalized response, measured and model."""
        n = self.judged.stop - self.judged.start
        return {"response_rms_measured": float(np.sqrt(np.mean(self.data.force[:n] ** 2))),
                "response_rms_model": float(np.sqrt(np.mean(model_force[:n] ** 2)))}

    def channel_part(self, i: int, step: int = 1) -> slice:
        """Channel ``i``'s samples in a stacked series over the judged samples (the record's
        normalized responses ``data.force``, a model's :meth:`predict`)."""
        n = self.judged.stop - self.judged.start
        return slice(i * n, (i + 1) * n, step)

    def in_units(self, i: int, stacked: np.ndarray, step: int = 1) -> np.ndarray:
        """Channel ``i`` of a stacked normalized series in its own SI unit (mean removed)."""
        return np.asarray(stacked)[self.channel_part(i, step)] * self.scales[i]

    def channel_noise(self) -> np.ndarray:
        return np.array([np.sqrt(difference_variance(self.data.force[self.channel_part(i)]))
                         for i in range(len(self.channels))])

    def noise(self) -> RunNoise:
        eq = float(np.sqrt(np.mean(self.channel_noise() ** 2)))
        rms = float(np.sqrt(np.mean(self.data.force ** 2)))
        return RunNoise(self.name, float("nan"), float("nan"), eq, eq / rms if rms > 0 else float("nan"),
                        int(self.spans.shape[0]), 0)

    def renamed(self, name: str) -> ModalMeasurement:
        return replace(self, name=name, data=self.data.renamed(name))


def path_filters(vals: Mapping[str, Any]) -> tuple[float, float]:
    """The shaker path's high-pass corner (Hz) and lag (s) in ``vals`` (0 when absent)."""
    out = []
    for n in ("shaker.highpass_hz", "shaker.lag_s"):
        v = vals.get(n, 0.0) or 0.0
        out.append(float(getattr(v, "value", v)))
    return out[0], out[1]
