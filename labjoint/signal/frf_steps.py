"""FRF sets from step-sine runs: per step the force phasor at f, the drive-voltage phasor
and each response sensor's phasors at h f, by least squares on whole cycles.

A step's record (recorded after the plan's steady-state wait) is cut into ``segments``
pieces of whole drive cycles; in each piece a constant and cos/sin at h f (h = 1..H) are
fitted by least squares (exact for whole cycles); the phasor is the mean over the pieces
and its standard deviation the scatter between them over sqrt(pieces) (std of the mean).
Phasors follow :mod:`labjoint.signal.frfset`: a cos(h w t + phi) -> a exp(i phi), t from
the run's first sample.

>>> fs, f = 2000.0, 25.0
>>> t = np.arange(4000) / fs
>>> x = 3.0 * np.cos(2 * np.pi * f * t + 0.5) + 0.2 * np.cos(2 * np.pi * 3 * f * t)
>>> p, sd = phasors(x, fs, f, harmonics=3, segments=4)
>>> np.round(np.abs(p), 6).tolist(), round(float(np.angle(p[0])), 6)
([3.0, 0.0, 0.2], 0.5)
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.frfset import FrfSet
from labjoint.storage.reader import open_run


def phasors(x: np.ndarray, fs: float, f: float, harmonics: int = 1, segments: int = 8,
            first_sample: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(H,) mean phasors at h f over ``segments`` pieces of whole cycles, and their std of the mean."""
    x = np.asarray(x, float)
    per = fs / f
    n_cyc = int(np.floor(x.size / per + 1e-9))
    if n_cyc < segments or segments < 2:
        raise InputError(f"need at least {max(segments, 2)} whole cycles of {f:g} Hz, have {n_cyc}",
                         field="segments")
    cyc_per = n_cyc // segments
    h = np.arange(1, harmonics + 1)
    out = np.empty((segments, harmonics), complex)
    for s in range(segments):
        a = int(round(s * cyc_per * per))
        b = int(round((s + 1) * cyc_per * per))
        t = (first_sample + np.arange(a, b)) / fs
        wt = 2 * np.pi * f * np.outer(t, h)
        A = np.hstack([np.ones((b - a, 1)), np.cos(wt), np.sin(wt)])
        c = np.linalg.lstsq(A, x[a:b], rcond=None)[0]
        out[s] = c[1:1 + harmonics] - 1j * c[1 + harmonics:]
    mean = out.mean(axis=0)
    sd = np.sqrt(np.sum(np.abs(out - mean) ** 2, axis=0) / ((segments - 1) * segments))
    return mean, sd


#: a record is clipped when more than this fraction of its samples sit at its largest |V|
CLIPPED_FRACTION = 0.01


def _clipped(volts: np.ndarray) -> bool:
    """More than ``CLIPPED_FRACTION`` of the samples sit at the largest |V|: the input range
    was exceeded (a sine has about one sample per cycle within 1e-6 of its peak, a clipped
    one a plateau), and its phasors would be wrong."""
    a = np.abs(np.asarray(volts, float))
    top = float(a.max()) if a.size else 0.0
    n = int(np.count_nonzero(a >= top * (1 - 1e-6))) if top > 0 else 0
    return n > max(3, CLIPPED_FRACTION * a.size)


def _step(path: Path, sensors: Sequence[str] | None, harmonics: int, segments: int,
          settle_fraction: float) -> dict[str, Any]:
    with open_run(path) as rf:
        md = rf.metadata
        if md.get("plan") != "step_sine":
            raise InputError(f"{path}: not a step_sine run (plan {md.get('plan')!r})", field="plan")
        for key in ("frequency_hz", "target_force_n", "direction"):
            if md.get(key) is None:
                raise InputError(f"{path}: run metadata lacks {key}", field=key)
        names = rf.channel_names
        ref = md.get("reference_force_channel") or "force"
        if ref not in names:
            raise InputError(f"{path}: no reference force channel {ref!r}; channels: {names}",
                             field="reference_force_channel")
        resp = list(sensors) if sensors is not None else [c for c in names if rf.channel(c).quantity == "acceleration"]
        missing = [s for s in resp if s not in names]
        if missing or not resp:
            raise InputError(f"{path}: no response channel(s) {missing or '(acceleration)'}; channels: {names}",
                             field="sensors")
        volt = [c for c in names if rf.channel(c).quantity == "voltage"]
        for c in (ref, *resp):
            if _clipped(rf.volts(c)):
                raise InputError(f"{path}: channel {c!r} is clipped at the input range: use a less "
                                 "sensitive sensor or a lower level", field="sensors")
        volt = [c for c in volt[:1] if not _clipped(rf.volts(c))]   # a clipped drive: no per-volt FRF
        f, fs = float(md["frequency_hz"]), rf.sample_rate_hz
        n = int(rf.time().size)
        start = int(settle_fraction * n)
        read = lambda c: rf.physical(c, start)  # noqa: E731
        force, _ = phasors(read(ref), fs, f, 1, segments, start)
        r = [phasors(read(s), fs, f, harmonics, segments, start) for s in resp]
        drive = phasors(read(volt[0]), fs, f, 1, segments, start)[0][0] if volt else None
        return {"f": f, "level": float(md["target_force_n"]), "direction": str(md["direction"]),
                "force": force[0], "response": np.array([p for p, _ in r]), "std": np.array([s for _, s in r]),
                "drive": drive, "sensors": tuple(resp), "run": path.name,
                "converged": bool(md.get("force_converged", True)), "error": md.get("force_error")}


def frfset_from_runs(runs: Iterable[str | Path], sensors: Sequence[str] | None = None, harmonics: int = 3,
                     segments: int = 8, settle_fraction: float = 0.0) -> FrfSet:
    """An :class:`FrfSet` of step_sine run files (levels and directions from their metadata).

    ``sensors``: the response channels (default: every acceleration channel);
    ``settle_fraction`` of each record is skipped first; steps whose force did not
    converge are kept and listed in ``metadata["unconverged"]``; ``force_error`` is the
    plan's (measured before recording), ``force_error_recorded`` that of the record itself.
    """
    steps = [_step(Path(p), sensors, harmonics, segments, settle_fraction) for p in runs]
    if not steps:
        raise InputError("no runs given", field="runs")
    names = steps[0]["sensors"]
    for s in steps:
        if s["sensors"] != names:
            raise InputError(f"{s['run']}: response channels {s['sensors']} differ from {names}", field="sensors")
    has_v = all(s["drive"] is not None for s in steps)
    return FrfSet(frequencies_hz=[s["f"] for s in steps], level_n=[s["level"] for s in steps],
                  direction=[s["direction"] for s in steps], force=[s["force"] for s in steps],
                  sensors=names, response=np.array([s["response"] for s in steps]),
                  response_std=np.array([s["std"] for s in steps]), quantity="acceleration",
                  drive_v=[s["drive"] for s in steps] if has_v else None,
                  runs=tuple(s["run"] for s in steps),
                  metadata={"source": "step_sine", "segments": segments,
                            "unconverged": [s["run"] for s in steps if not s["converged"]],
                            "force_error": [s["error"] for s in steps],
                            "force_error_recorded": [abs(abs(s["force"]) - s["level"]) / s["level"]
                                                     for s in steps]})
