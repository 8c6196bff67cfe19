"""A run file, CSV record or channel record as a measurement of the ``modal`` kind
(:mod:`.modal`): the drive and the response channels checked against the measured modes,
a steady sine's window (the last ``warmup + judge`` seconds before its drive stops, its
drive's own frequency) or a record's whole length, and the units of the paired test."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from labjoint.compare.kinds.modal import BLOCKS, END_MARGIN_S, JUDGE_S, WARMUP_S, ModalMeasurement
from labjoint.errors import InputError
from labjoint.models import RunData
from labjoint.models.inputs import ModelInputs, estimate_frequency
from labjoint.storage.channels import ChannelRecord
from labjoint.storage.reader import read_channels
from labjoint.structure.nlmode import QUANTITY_ORDER, Drive, ModalBasis, linear_states
from labjoint.structure.nlmode_pair import differences


def _spans(n: int, n_ch: int) -> np.ndarray:
    size = max(1, n // BLOCKS)
    starts = np.arange(0, n - size + 1, size)
    one = np.column_stack([starts, starts + size])
    return np.vstack([one + i * n for i in range(n_ch)])


def _drive_end(v: np.ndarray, fs: float) -> int:
    """Where a steady sine's drive ends (BERT's sine tests stop the drive 12 s before the
    record ends): the end of the last quarter-second block whose rms is above half the
    largest, less ``END_MARGIN_S``."""
    b = max(1, int(fs / 4))
    nb = v.size // b
    rms = np.sqrt(np.mean(np.asarray(v[:nb * b], float).reshape(nb, b) ** 2, axis=1))
    on = np.flatnonzero(rms > 0.5 * rms.max())
    end = (int(on[-1]) + 1) * b if on.size else v.size
    return min(v.size, max(b, end - int(END_MARGIN_S * fs)))


def prepare_modal(path: str | ChannelRecord, basis: ModalBasis, responses: Sequence[str] | None = None,
                  warmup_s: float = WARMUP_S, judge_s: float = JUDGE_S,
                  between: tuple[str, str] | None = None) -> ModalMeasurement:
    """A run file, CSV record or channel record as a modal measurement (module docstring);
    ``between``: two sensors of the modes the joint acts between (else on mode 1)."""
    if between is not None:
        differences(basis, *between)
    rec = path if isinstance(path, ChannelRecord) else read_channels(path)
    path = rec.path if isinstance(path, ChannelRecord) else path
    drives = rec.drives
    if len(drives) != 1:
        raise InputError(f"the modal kind needs one drive channel (a voltage or a force), the record "
                         f"has {[c.name for c in drives]}", file=str(path), field="drive")
    dr = drives[0]
    if dr.quantity not in ("voltage", "force"):
        raise InputError(f"the drive {dr.name!r} is a {dr.quantity}, not a voltage or a force",
                         file=str(path), field="drive")
    names = list(responses) if responses else [c.name for c in rec.responses
                                               if c.quantity in QUANTITY_ORDER]
    sensors = basis.modes[0].shape
    for ch in names:
        c = rec.channel(ch)
        if c.quantity not in QUANTITY_ORDER:
            raise InputError(f"channel {ch!r} is a {c.quantity}; the modal kind compares "
                             "displacement, velocity or acceleration", file=str(path), field=ch)
        if sensors and ch not in sensors:
            raise InputError(f"channel {ch!r} is not a sensor of the modes ({sorted(sensors)})",
                             file=str(path), field=ch)
    if basis.reference not in names:
        raise InputError(f"the reference sensor {basis.reference!r} must be among the responses",
                         file=str(path), field="responses")
    names.sort(key=lambda c: c != basis.reference)
    fs = float(rec.sample_rate_hz)
    f = rec.metadata.get("frequency_hz")
    if f:       # the drive's own frequency (a test's nominal one can be off: BERT's 19 Hz is 18.875)
        f = estimate_frequency(dr.samples[:_drive_end(dr.samples, float(rec.sample_rate_hz))],
                               float(rec.sample_rate_hz))
        if abs(f / float(rec.metadata["frequency_hz"]) - 1) > 0.1:
            raise InputError(f"the drive's frequency {f:.4g} Hz is not the stated "
                             f"{rec.metadata['frequency_hz']} Hz", file=str(path), field="frequency_hz")
    n_all = rec.time.size
    if f:
        end = _drive_end(dr.samples, fs)
        per = fs / f
        k = max(1, int(round(judge_s * f)))
        n_judge = int(round(k * per))
        n_seg = min(end, n_judge + int(round(warmup_s * fs)))
        if n_seg <= n_judge:
            raise InputError(f"{end / fs:.3g} s of drive is too short for {judge_s:g} s judged after "
                             f"{warmup_s:g} s of warm-up", file=str(path), field="warmup")
        seg = slice(end - n_seg, end)
        judged = slice(n_seg - n_judge, n_seg)
    else:
        seg, judged = slice(0, n_all), slice(0, n_all)
    drive = Drive.of(dr.samples[seg], fs, f, max(m.frequency_hz for m in basis.modes))
    meas, scales = [], []
    for ch in names:
        y = np.asarray(rec.channel(ch).samples[seg], float)[judged]
        y = y - y.mean()
        s = float(np.sqrt(np.mean(y * y)))
        if not s > 0:
            raise InputError("the channel is silent on the judged samples", file=str(path), field=ch)
        meas.append(y / s)
        scales.append(s)
    lin = tuple(linear_states(m, drive) for m in basis.linear)
    y = np.concatenate(meas)
    z = np.zeros(y.size)
    level = rec.metadata.get("level")
    inputs = ModelInputs(z, z, z, fs, 0, 0.0, f or basis.modes[0].frequency_hz, rec.name,
                         {"kind": "modal"})
    qts = tuple(rec.channel(c).quantity for c in names)
    n = judged.stop - judged.start
    return ModalMeasurement(rec.name, basis, drive, tuple(names), qts, judged, np.array(scales), lin, RunData(inputs, y, np.ones(y.size, bool)),
                            _spans(n, len(names)),
                            float(level) if level is not None else None, str(path),
                            {**rec.metadata, "drive_channel": dr.name, "drive_quantity": dr.quantity},
                            between=tuple(between) if between else None)
