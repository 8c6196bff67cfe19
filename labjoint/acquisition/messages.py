"""The small commands a plan yields, and what the engine sends back (bluesky-style).

A plan is a generator of these messages; :class:`~labjoint.acquisition.engine.RunEngine`
executes them. Messages only describe intent: they check that values are physically
meaningful (finite, positive...) but never check the rig's safety limits, which live in
:mod:`labjoint.acquisition.safety` and are applied by the engine alone.

>>> Configure(400, 20)
Configure(frequency_hz=400.0, amplitude_vpp=20.0, offset_v=0.0)
>>> Record("dwell_400Hz", n_cycles=50).n_cycles
50
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from labjoint.errors import InputError

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,150}$")


def _finite(value: Any, name: str, *, positive: bool = False, nonneg: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"must be a number, got {value!r}", field=name) from None
    if not math.isfinite(x):
        raise InputError(f"must be finite, got {value!r}", field=name)
    if positive and not x > 0:
        raise InputError(f"must be positive, got {value!r}", field=name)
    if nonneg and x < 0:
        raise InputError(f"must not be negative, got {value!r}", field=name)
    return x


def _count(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InputError(f"must be a positive integer, got {value!r}", field=name)
    return int(value)


def _set(obj: object, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


@dataclass(frozen=True)
class Configure:
    """Set the sine: frequency, peak-to-peak amplitude and offset (the engine ramps Vpp)."""

    frequency_hz: float
    amplitude_vpp: float
    offset_v: float = 0.0

    def __post_init__(self) -> None:
        _set(self, "frequency_hz", _finite(self.frequency_hz, "frequency_hz", positive=True))
        _set(self, "amplitude_vpp", _finite(self.amplitude_vpp, "amplitude_vpp", nonneg=True))
        _set(self, "offset_v", _finite(self.offset_v, "offset_v"))


@dataclass(frozen=True)
class LoadWaveform:
    """Load one period of an arbitrary waveform (``points``, peak-normalised) and select it,
    repeated ``frequency_hz`` times per second at ``amplitude_vpp`` (2 x its peak). The
    output must be off; ``band_hz`` (lowest, highest frequency it holds) is what the
    frequency limits are checked against, and ``excitation`` describes it in the runs'
    metadata. Then :class:`Output`, :class:`Ramp` and :class:`Record` work as for a sine
    (``n_cycles`` counts periods)."""

    points: tuple[float, ...] = field(repr=False)
    frequency_hz: float
    amplitude_vpp: float
    band_hz: tuple[float, float]
    offset_v: float = 0.0
    excitation: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        pts = tuple(float(x) for x in self.points)
        if not 2 <= len(pts) <= 8192 or not all(math.isfinite(x) for x in pts):
            raise InputError(f"a waveform has 2..8192 finite points, got {len(pts)}", field="points")
        if max(abs(x) for x in pts) == 0:
            raise InputError("the waveform is constant zero", field="points")
        _set(self, "points", pts)
        _set(self, "frequency_hz", _finite(self.frequency_hz, "frequency_hz", positive=True))
        _set(self, "amplitude_vpp", _finite(self.amplitude_vpp, "amplitude_vpp", nonneg=True))
        _set(self, "offset_v", _finite(self.offset_v, "offset_v"))
        lo, hi = (_finite(v, "band_hz", positive=True) for v in self.band_hz)
        if hi < lo:
            raise InputError(f"band must be (low, high), got {self.band_hz!r}", field="band_hz")
        _set(self, "band_hz", (lo, hi))
        if not isinstance(self.excitation, dict):
            raise InputError("must be a mapping", field="excitation")


@dataclass(frozen=True)
class Ramp:
    """Change only the amplitude, ramped at the limits' rate."""

    to_vpp: float

    def __post_init__(self) -> None:
        _set(self, "to_vpp", _finite(self.to_vpp, "to_vpp", nonneg=True))


@dataclass(frozen=True)
class Output:
    """Switch the generator output on (ramping up from the floor) or off (ramping down)."""

    on: bool

    def __post_init__(self) -> None:
        if not isinstance(self.on, bool):
            raise InputError(f"must be true or false, got {self.on!r}", field="on")


@dataclass(frozen=True)
class SetTorque:
    """Bolt tightening torque (N*m). The engine ramps the output off first; on the
    simulated rig it applies the torque, on a real one it waits on its torque gate until
    the operator confirms (with the torque actually applied); then it restores the
    output if it was on."""

    torque_nm: float

    def __post_init__(self) -> None:
        _set(self, "torque_nm", _finite(self.torque_nm, "torque_nm", positive=True))


@dataclass(frozen=True)
class WaitSteady:
    """Acquire (without storing) until the per-cycle displacement amplitude of every
    displacement channel drifts by at most ``tol`` (relative, line fit) over ``window``
    cycles, or ``max_cycles`` have passed. The engine answers with a :class:`SteadyResult`."""

    max_cycles: int
    tol: float
    window: int = 10

    def __post_init__(self) -> None:
        _count(self.max_cycles, "max_cycles")
        _count(self.window, "window")
        _set(self, "tol", _finite(self.tol, "tol", positive=True))
        if self.window < 2:
            raise InputError(f"must be at least 2 cycles, got {self.window}", field="window")


@dataclass(frozen=True)
class Measure:
    """Acquire ``n_cycles`` (not stored) and answer with a :class:`Measurement` of every
    channel's amplitude at the drive frequency (closed-loop plans use it)."""

    n_cycles: int

    def __post_init__(self) -> None:
        _count(self.n_cycles, "n_cycles")


@dataclass(frozen=True)
class Record:
    """Record one run of ``n_cycles`` drive cycles or ``duration_s`` seconds.

    ``metadata`` (JSON-serialisable) is added to the run's metadata; the engine's own
    keys (frequency, amplitude, torque, times...) take precedence over it.
    """

    name: str
    n_cycles: int | None = None
    duration_s: float | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME_RE.match(self.name):
            raise InputError(f"run name {self.name!r} must be 1-151 of [A-Za-z0-9_.-] "
                             "starting with a letter or digit", field="name")
        if (self.n_cycles is None) == (self.duration_s is None):
            raise InputError("give exactly one of n_cycles and duration_s", field="n_cycles")
        if self.n_cycles is not None:
            _count(self.n_cycles, "n_cycles")
        else:
            _set(self, "duration_s", _finite(self.duration_s, "duration_s", positive=True))
        if not isinstance(self.metadata, dict):
            raise InputError(f"must be a mapping, got {type(self.metadata).__name__}", field="metadata")


@dataclass(frozen=True)
class Checkpoint:
    """A named point in the plan: shown as the engine's progress and copied into the
    metadata (``checkpoint``) of the runs recorded after it."""

    label: str
    data: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Pause:
    """Ramp the output off and wait for the operator to continue (through the engine's
    gate; skipped on the simulated rig when there is no gate), then restore the output."""

    reason: str


Message = Configure | LoadWaveform | Ramp | Output | SetTorque | WaitSteady | Measure | Record | Checkpoint | Pause


# ---- answers the engine sends back into the plan --------------------------------------

@dataclass(frozen=True)
class SteadyResult:
    """Outcome of :class:`WaitSteady`: ``drift`` is the largest relative change of the
    per-cycle amplitude across the last window (line fit); ``amplitude_m`` the last
    per-cycle displacement amplitudes (m) by channel."""

    reached: bool
    cycles: int
    drift: float
    amplitude_m: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"reached": self.reached, "cycles": self.cycles, "drift": self.drift,
                "amplitude_m": dict(self.amplitude_m)}


@dataclass(frozen=True)
class Measurement:
    """Amplitude (SI units, via each channel's calibration at the drive frequency) and
    phase (rad, of a cosine referred to the first sample) of every channel's fundamental,
    plus the engine's amplitude limit so closed-loop plans can saturate below it."""

    frequency_hz: float
    amplitude: dict[str, float]
    phase_rad: dict[str, float]
    reference_force_channel: str | None = None
    max_vpp: float = math.inf
    #: largest |volts| / input range of each channel over the measured cycles (1: clipped)
    peak_fraction: dict[str, float] = field(default_factory=dict)

    @property
    def reference_force_n(self) -> float:
        """Amplitude (N) on the reference force channel."""
        if self.reference_force_channel is None:
            raise InputError("the rig has no reference force channel", field="reference_force_channel")
        return self.amplitude[self.reference_force_channel]


@dataclass(frozen=True)
class RecordResult:
    """Answer to :class:`Record`: the run's uid, name and final status."""

    uid: str
    name: str
    status: str
    n_samples: int


@dataclass
class PlanResult:
    """How a plan ended, and every run it recorded."""

    status: str
    reason: str = ""
    runs: list[RecordResult] = field(default_factory=list)
