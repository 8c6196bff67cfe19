"""Constant-force stepped-sine FRFs of a structure, with their harmonics (seed 000 Sec. 4).

One :class:`FrfSet` holds every step of one or more step-sine sweeps: per step the drive
frequency f, the force level aimed at, the sweep direction, the achieved force phasor at
f, the generator voltage phasor (for labs without a force sensor, responses per volt),
and per sensor the response phasors at h f for h = 1..H (acceleration, m/s^2), each with
the standard deviation of its estimate (the noise floor of the comparison).

A broadband FRF (:mod:`labjoint.signal.broadband`) is stored in the same contract: one
"step" per frequency line, ``level_n`` the record's level, ``force`` the unit phasor (1 in
the drive's unit) so that ``response`` is the FRF itself, ``estimator`` H1, H2 or Hv, and
``coherence`` per line and sensor; ``alternatives`` holds the other estimators of the
same lines ({"H2": (n, S), "Hv": (n, S)}, NaN where one is undefined). ``drive_quantity`` says what the drive is: "force"
(N) or "voltage" (V, an amplifier or generator output; then ``level_n`` and ``force``
are in volts, never newtons: :attr:`FrfSet.units`, e.g. "m/s/V", says so).

Phasor convention: a signal a cos(h w t + phi) has phasor a exp(i phi) at harmonic h
(amplitude, not RMS). The accelerance at step k, sensor s is
``response[k, s, 0] / force[k]``.

>>> s = FrfSet(frequencies_hz=[27.0, 28.0], level_n=[16.5, 16.5], direction=["up", "up"],
...            force=[16.4 + 0j, 16.6 + 0j], sensors=("tip",),
...            response=np.ones((2, 1, 3), complex), response_std=np.full((2, 1, 3), 0.01))
>>> s.harmonics, [k for k, _ in s.groups()]
(3, [(16.5, 'up')])
>>> FrfSet.from_dict(s.to_dict()) == s
True
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from labjoint.errors import InputError

FORMAT = "labjoint.frfset/1"
QUANTITIES = ("acceleration", "velocity", "displacement")
#: SI unit of each response quantity and of each drive quantity
RESPONSE_UNITS = {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m"}
DRIVES = {"force": "N", "voltage": "V"}
ESTIMATORS = ("stepped_sine", "H1", "H2", "Hv")


def _complex(a: Any, name: str) -> np.ndarray:
    try:
        return np.asarray(a, dtype=complex)
    except (TypeError, ValueError):
        raise InputError("must be complex numbers", field=name) from None


@dataclass(frozen=True, eq=False)
class FrfSet:
    """Stepped-sine steps (n), sensors (S), harmonics (H); SI units, phasors as amplitudes."""

    frequencies_hz: np.ndarray          # (n,) drive frequency of each step
    level_n: np.ndarray                 # (n,) force amplitude aimed at (groups the steps)
    direction: np.ndarray               # (n,) 'up' or 'down'
    force: np.ndarray                   # (n,) achieved force phasor at f, N
    sensors: tuple[str, ...]            # response sensor names (the structure file's)
    response: np.ndarray                # (n, S, H) response phasors at h f
    response_std: np.ndarray            # (n, S, H) std of each phasor estimate (>= 0)
    quantity: str = "acceleration"      # what response measures (m/s^2, m/s or m)
    drive_v: np.ndarray | None = None   # (n,) generator voltage phasor at f, V (or None)
    runs: tuple[str, ...] = ()          # the run each step came from (or empty)
    metadata: dict[str, Any] = field(default_factory=dict)
    drive_quantity: str = "force"       # "force" (N) or "voltage" (V): the unit of force, level_n
    estimator: str = "stepped_sine"     # or a broadband estimator: H1, H2, Hv
    coherence: np.ndarray | None = None  # (n, S) coherence of a broadband estimate (or None)
    alternatives: dict[str, np.ndarray] = field(default_factory=dict)  # other estimators, (n, S)

    def __post_init__(self) -> None:
        put = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 - frozen dataclass
        f = np.asarray(self.frequencies_hz, float)
        n = f.size
        if f.ndim != 1 or n == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise InputError("must be a non-empty list of positive frequencies", field="frequencies_hz")
        put("frequencies_hz", f)
        lv = np.asarray(self.level_n, float)
        if lv.shape != (n,) or not np.all(lv > 0):
            raise InputError(f"must be {n} positive force levels", field="level_n")
        put("level_n", lv)
        d = np.asarray(self.direction, dtype=str)
        if d.shape != (n,) or not set(d.tolist()) <= {"up", "down"}:
            raise InputError(f"must be {n} of 'up' or 'down'", field="direction")
        put("direction", d)
        fc = _complex(self.force, "force")
        if fc.shape != (n,) or not np.all(np.isfinite(fc)) or np.any(fc == 0):
            raise InputError(f"must be {n} non-zero finite force phasors", field="force")
        put("force", fc)
        sensors = tuple(str(s) for s in self.sensors)
        if not sensors or len(set(sensors)) != len(sensors):
            raise InputError("must be distinct sensor names, at least one", field="sensors")
        put("sensors", sensors)
        r = _complex(self.response, "response")
        if r.ndim != 3 or r.shape[:2] != (n, len(sensors)) or r.shape[2] < 1 or not np.all(np.isfinite(r)):
            raise InputError(f"must be finite, shaped (steps {n}, sensors {len(sensors)}, harmonics)",
                             field="response")
        put("response", r)
        sd = np.asarray(self.response_std, float)
        if sd.shape != r.shape or not np.all(sd >= 0):
            raise InputError(f"must be {r.shape} non-negative standard deviations", field="response_std")
        put("response_std", sd)
        if self.quantity not in QUANTITIES:
            raise InputError(f"must be one of {QUANTITIES}", field="quantity")
        if self.drive_v is not None:
            v = _complex(self.drive_v, "drive_v")
            if v.shape != (n,) or not np.all(np.isfinite(v)):
                raise InputError(f"must be {n} finite voltage phasors", field="drive_v")
            put("drive_v", v)
        runs = tuple(str(x) for x in self.runs)
        if runs and len(runs) != n:
            raise InputError(f"must name {n} runs or none", field="runs")
        put("runs", runs)
        if self.drive_quantity not in DRIVES:
            raise InputError(f"must be one of {list(DRIVES)}", field="drive_quantity")
        if self.estimator not in ESTIMATORS:
            raise InputError(f"must be one of {ESTIMATORS}", field="estimator")
        if self.coherence is not None:
            c = np.asarray(self.coherence, float)
            if c.shape != r.shape[:2] or not np.all((c >= 0) & (c <= 1)):
                raise InputError(f"must be {r.shape[:2]} values in [0, 1]", field="coherence")
            put("coherence", c)
        alt = {}
        for k, v in dict(self.alternatives).items():
            a = _complex(v, f"alternatives.{k}")
            if k not in ESTIMATORS[1:] or a.shape != r.shape[:2]:
                raise InputError(f"must be H1, H2 or Hv shaped {r.shape[:2]}", field=f"alternatives.{k}")
            alt[k] = a
        put("alternatives", alt)

    @property
    def units(self) -> str:
        """The FRF's unit, response over drive, e.g. "m/s^2/N" or "m/s/V"."""
        return f"{RESPONSE_UNITS[self.quantity]}/{DRIVES[self.drive_quantity]}"

    @property
    def level_units(self) -> str:
        """The unit of ``level_n`` and ``force``: "N" or "V"."""
        return DRIVES[self.drive_quantity]

    @property
    def harmonics(self) -> int:
        """H, the number of response harmonics per step."""
        return int(self.response.shape[2])

    def __len__(self) -> int:
        return int(self.frequencies_hz.size)

    def accelerance(self, harmonic: int = 1) -> np.ndarray:
        """(n, S) response at ``harmonic`` x f over the force phasor at f."""
        return self.response[:, :, harmonic - 1] / self.force[:, None]

    def groups(self) -> Iterator[tuple[tuple[float, str], np.ndarray]]:
        """((level, direction), step indices in sweep order) per sweep, levels ascending."""
        keys = sorted({(float(lv), str(d)) for lv, d in zip(self.level_n, self.direction)},
                      key=lambda k: (k[0], k[1] != "up"))
        for lv, d in keys:
            yield (lv, d), np.flatnonzero((self.level_n == lv) & (self.direction == d))

    def subset(self, index: Any) -> "FrfSet":
        """The steps selected by ``index`` (a mask or indices), same sensors and harmonics."""
        idx = np.arange(len(self))[index]
        return FrfSet(self.frequencies_hz[idx], self.level_n[idx], self.direction[idx],
                      self.force[idx], self.sensors, self.response[idx], self.response_std[idx],
                      self.quantity, None if self.drive_v is None else self.drive_v[idx],
                      tuple(self.runs[i] for i in idx) if self.runs else (), dict(self.metadata),
                      self.drive_quantity, self.estimator,
                      None if self.coherence is None else self.coherence[idx],
                      {k: v[idx] for k, v in self.alternatives.items()})

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        """Plain JSON types; complex numbers as [re, im] pairs (``arrays``: the numeric
        fields as float arrays, for a writer that takes them)."""
        lst = np.ascontiguousarray if arrays else (lambda a: a.tolist())  # noqa: E731
        c = lambda a: lst(np.stack([a.real, a.imag], -1))  # noqa: E731
        return {"format": FORMAT, "frequencies_hz": lst(self.frequencies_hz),
                "level_n": lst(self.level_n), "direction": self.direction.tolist(),
                "force": c(self.force), "sensors": list(self.sensors), "response": c(self.response),
                "response_std": lst(self.response_std), "quantity": self.quantity,
                "drive_v": None if self.drive_v is None else c(self.drive_v),
                "runs": list(self.runs), "metadata": self.metadata,
                "drive_quantity": self.drive_quantity, "units": self.units,
                "level_units": self.level_units, "estimator": self.estimator,
                "coherence": None if self.coherence is None else lst(self.coherence),
                "alternatives": {k: c(v) for k, v in self.alternatives.items()}}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "FrfSet":
        """Inverse of :meth:`to_dict`; a wrong format or missing key names the key."""
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise InputError(f"not an FRF set (format must be {FORMAT!r})", field="format")

        def c(key: str, value: Any = None) -> Any:
            a = np.asarray(d[key] if value is None else value, float)   # null -> NaN
            if a.ndim == 0 or a.shape[-1] != 2:
                raise InputError("must be [re, im] pairs", field=key)
            return a[..., 0] + 1j * a[..., 1]
        try:
            return cls(d["frequencies_hz"], d["level_n"], d["direction"], c("force"),
                       tuple(d["sensors"]), c("response"), d["response_std"],
                       d.get("quantity", "acceleration"),
                       None if d.get("drive_v") is None else c("drive_v"),
                       tuple(d.get("runs", ())), dict(d.get("metadata", {})),
                       d.get("drive_quantity", "force"), d.get("estimator", "stepped_sine"),
                       d.get("coherence"),
                       {k: c(f"alternatives.{k}", d["alternatives"][k]) for k in d.get("alternatives") or {}})
        except KeyError as exc:
            raise InputError("missing from the FRF set", field=str(exc.args[0])) from None
        except (TypeError, ValueError) as exc:
            raise InputError(f"unreadable FRF set: {exc}", field="frfset") from None

    def save(self, path: str | Path) -> Path:
        """Write as JSON in one step (a temporary file renamed over the target). orjson
        writes the arrays straight from numpy (a broadband set holds 10^5-10^6 numbers:
        the standard encoder took most of `labjoint frf`'s time on a 10-minute record)."""
        import orjson

        p = writable_path(path)
        tmp = p.with_name(f".{p.name}.tmp")
        try:
            tmp.write_bytes(orjson.dumps(self.to_dict(arrays=True),
                                         option=orjson.OPT_SERIALIZE_NUMPY))
            os.replace(tmp, p)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise InputError(f"cannot write the FRF set ({exc.strerror})", file=str(p),
                             field="out") from None
        return p

    @classmethod
    def load(cls, path: str | Path) -> "FrfSet":
        """Read a file written by :meth:`save` (or any JSON of the format); errors name the file."""
        import orjson

        p = Path(path)
        try:
            d = orjson.loads(p.read_bytes())
        except (OSError, orjson.JSONDecodeError) as exc:
            raise InputError(f"not a readable FRF set ({exc})", file=str(p)) from None
        try:
            return cls.from_dict(d)
        except InputError as exc:   # a bad key or array: the one line names the file too
            if exc.file is not None:
                raise
            raise InputError(exc.message, file=str(p), line=exc.line, column=exc.column,
                             field=exc.field) from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FrfSet):
            return NotImplemented
        for f in fields(self):
            a, b = getattr(self, f.name), getattr(other, f.name)
            if f.name == "alternatives":
                if a.keys() != b.keys() or not all(np.array_equal(a[k], b[k], equal_nan=True) for k in a):
                    return False
                continue
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                if a is None or b is None or not np.array_equal(a, b):
                    return False
            elif a != b:
                return False
        return True

    __hash__ = None  # type: ignore[assignment]


def concat(sets: "list[FrfSet]") -> FrfSet:
    """One FrfSet of several (their common harmonics; the sensors must be the same)."""
    if len(sets) == 1:
        return sets[0]
    if len({s.sensors for s in sets}) > 1:
        raise InputError("the FRF sets name different sensors", field="frfsets")
    if len({s.quantity for s in sets}) > 1:
        raise InputError("the FRF sets measure different quantities", field="frfsets")
    if len({s.drive_quantity for s in sets}) > 1:
        raise InputError("the FRF sets have different drives (force and voltage)", field="frfsets")
    H = min(s.harmonics for s in sets)
    coh = (None if any(s.coherence is None for s in sets)
           else np.concatenate([s.coherence for s in sets]))
    est = {s.estimator for s in sets}
    common = set.intersection(*(set(s.alternatives) for s in sets))
    alts = {k: np.concatenate([s.alternatives[k] for s in sets]) for k in sorted(common)}
    if len(est) > 1:
        raise InputError(f"the FRF sets mix estimators {sorted(est)}", field="frfsets")
    cat = lambda f: np.concatenate([f(s) for s in sets])  # noqa: E731
    return FrfSet(cat(lambda s: s.frequencies_hz), cat(lambda s: s.level_n),
                  cat(lambda s: s.direction), cat(lambda s: s.force), sets[0].sensors,
                  cat(lambda s: s.response[:, :, :H]), cat(lambda s: s.response_std[:, :, :H]),
                  sets[0].quantity,
                  runs=tuple(r for s in sets for r in s.runs) if all(s.runs for s in sets) else (),
                  drive_quantity=sets[0].drive_quantity,
                  estimator=est.pop(), coherence=coh, alternatives=alts)


def writable_path(path: str | Path) -> Path:
    """``path`` as a file to write: not a directory, in an existing directory (InputError
    naming it otherwise, before anything is computed or written)."""
    p = Path(path)
    if p.is_dir():
        raise InputError("is a directory: give a file name (e.g. frf.json)", file=str(p),
                         field="out")
    if not p.parent.is_dir():
        raise InputError(f"directory {str(p.parent)!r} does not exist", file=str(p), field="out")
    return p
