"""The ``frf`` kind: constant-force stepped-sine FRFs of a structure, with their harmonics.

Measurement (:class:`FrfMeasurement`): one sweep of an :class:`~labjoint.signal.frfset.FrfSet`
(a force level and a direction) around one mode (the steps nearest, in log frequency,
to one of the structure's linear natural frequencies), with the structure it was
measured on. The predictor is a joint model inside the structure
(:class:`~labjoint.structure.predict.FrfPredictor`: every joint's tangential law is the
model with its parameters; Craig-Bampton + harmonic balance at the measured steps in
sweep order), so the model's "force" of the comparison core is its response.

Residual: per step, sensor and harmonic h = 1..H the response phasor, model minus
measured, divided by its measurement std (``response_std`` / sqrt 2 per real and
imaginary part): whitened, so every phasor counts by its signal-to-noise ratio and the
harmonics 2 and 3 count where they stand above their noise. The core's "measured force"
is the whitened measured phasors (real and imaginary parts), its NRMSE therefore
rms(whitened residual) / rms(whitened measurement). Units (the paired test): each phasor
(a step, a sensor, a harmonic), whose noise is independent of the others' (each is
estimated from its own channel and frequency line).
Noise floor: the set's own response_std; whitened, its equivalent std is 1 and the
floor NRMSE 1 / rms(whitened measurement).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from labjoint.compare.measurement import RunNoise
from labjoint.errors import InputError
from labjoint.models import Model, Parameters, RunData
from labjoint.models.inputs import ModelInputs
from labjoint.signal.frfset import FrfSet
from labjoint.structure.predict import FrfPredictor
from labjoint.structure.stage2 import split_by_mode

METHOD = ("the FRF set's response_std of each phasor (residuals whitened by it: the floor is "
          "1 / rms of the whitened measured phasors)")
MIN_STD_FRACTION = 1e-6
#: steps a sweep needs around a resonance to show it (a peak and its two sides)
MIN_STEPS = 3


def whiten(resp: np.ndarray, std: np.ndarray) -> np.ndarray:
    """(n, S, H) phasors over their per-component std as a real vector, step-major:
    for each step, sensors x harmonics x (re, im)."""
    s = std / np.sqrt(2.0)
    z = resp / s
    return np.stack([z.real, z.imag], axis=-1).reshape(-1)


@dataclass(frozen=True, eq=False)
class FrfMeasurement:
    """One sweep around one mode, prepared (module docstring)."""

    kind: ClassVar[str] = "frf"
    noise_method: ClassVar[str] = METHOD
    name: str
    frfset: FrfSet
    predictor: FrfPredictor
    mode: int
    data: RunData
    std: np.ndarray
    path: str | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def level_n(self) -> float:
        return float(self.frfset.level_n[0])

    @property
    def direction(self) -> str:
        return str(self.frfset.direction[0])

    def units(self) -> np.ndarray:
        """One unit per phasor (step, sensor, harmonic: its real and imaginary parts)."""
        n = len(self.frfset) * len(self.frfset.sensors) * self.frfset.harmonics
        return np.column_stack([np.arange(n) * 2, np.arange(1, n + 1) * 2])

    def axes(self) -> dict[str, Any]:
        f = self.frfset.frequencies_hz
        return {"level_n": self.level_n, "direction": self.direction, "mode": self.mode + 1,
                "frequency_min_hz": float(f.min()), "frequency_max_hz": float(f.max()),
                "steps": len(self.frfset)}

    def phasors(self, vector: np.ndarray) -> np.ndarray:
        """Whitened vector (the core's force) back to (n, S, H) phasors."""
        z = vector.reshape(len(self.frfset), len(self.frfset.sensors), self.frfset.harmonics, 2)
        return (z[..., 0] + 1j * z[..., 1]) * self.std / np.sqrt(2.0)

    def predict_law(self, law: Any) -> np.ndarray:
        """The whitened response of the structure with every joint's law ``law``."""
        return whiten(self.predictor.predict(self.frfset, law, self.frfset.harmonics), self.std)

    def predict(self, model: Model, params: Parameters | dict) -> np.ndarray:
        """The model's whitened response at the steps (the core's model force)."""
        vals = {k: float(v.value if hasattr(v, "value") else v) for k, v in params.items()}
        return self.predict_law(self.predictor.law_of(model, {k: vals[k] for k in model.param_names}))

    def figures(self, model_force: np.ndarray) -> dict[str, float]:
        """Peak of the harmonic-1 response of the first sensor per newton: where and how high,
        measured and model."""
        f = self.frfset.frequencies_hz
        out = {}
        for side, v in (("measured", self.data.force), ("model", model_force)):
            a = np.abs(self.phasors(v)[:, 0, 0] / self.frfset.force)
            i = int(np.argmax(a))
            out[f"peak_frequency_{side}_hz"] = float(f[i])
            out[f"peak_response_{side}_per_n"] = float(a[i])
        return out

    def noise(self) -> RunNoise:
        f = self.data.force
        rms = float(np.sqrt(np.mean(f * f)))
        return RunNoise(self.name, float("nan"), float(np.median(self.std)), 1.0,
                        1.0 / rms if rms > 0 else float("nan"), len(self.frfset), 0)

    def renamed(self, name: str) -> FrfMeasurement:
        return replace(self, name=name, data=self.data.renamed(name))


def _data(name: str, fs: FrfSet, std: np.ndarray) -> RunData:
    y = whiten(fs.response, std)
    z = np.zeros(y.size)
    inputs = ModelInputs(z, z, z, 1.0, 0, 0.0, float(np.mean(fs.frequencies_hz)), name,
                         {"kind": "frf"})
    return RunData(inputs, y, np.ones(y.size, bool))


def prepare_frfsets(sets: Sequence[FrfSet | tuple[str, FrfSet]], predictor: FrfPredictor,
                    harmonics: int | None = None) -> list[FrfMeasurement]:
    """Measurements (one per sweep and mode) of FRF sets (or (name, set) pairs) on the
    predictor's structure; ``harmonics`` keeps the first H of the set's (all by default).
    A zero std (a noiseless set) is raised to ``MIN_STD_FRACTION`` of the phasor's size."""
    if not sets:
        raise InputError("no FRF sets given", field="runs")
    nat = predictor.natural_frequencies(2)
    out: list[FrfMeasurement] = []
    for i, item in enumerate(sets):
        name, fs = item if isinstance(item, tuple) else (str(item.metadata.get("name", f"frf{i}")), item)
        if not isinstance(fs, FrfSet):
            raise InputError(f"expected an FRF set, got {type(fs).__name__}", field="runs")
        predictor.rows(fs.sensors)
        H = fs.harmonics if harmonics is None else min(int(harmonics), fs.harmonics)
        mode = split_by_mode(fs.frequencies_hz, nat)
        for (lv, d), idx in fs.groups():
            for m in sorted(set(mode[idx].tolist())):
                sub = fs.subset(idx[mode[idx] == m])
                resp, sd = sub.response[:, :, :H], sub.response_std[:, :, :H]
                floor = MIN_STD_FRACTION * np.maximum(np.abs(resp[:, :, :1]), 1e-300)
                sd = np.maximum(sd, floor)
                sub = FrfSet(sub.frequencies_hz, sub.level_n, sub.direction, sub.force, sub.sensors,
                             resp, sd, sub.quantity, sub.drive_v, sub.runs, sub.metadata)
                nm = f"{name}@{lv:g}N-{d}-mode{m + 1}"
                if len(sub) < MIN_STEPS:
                    raise InputError(
                        f"sweep {nm} has {len(sub)} step(s) near mode {m + 1} ({nat[m]:.4g} Hz): too "
                        f"few near a resonance to decide; measure at least {MIN_STEPS} steps across "
                        f"it, no more than {2 * 0.01 * nat[m] / 4:.2g} Hz apart for 1 % damping",
                        file=fs.metadata.get("path"), field="frequencies_hz")
                out.append(FrfMeasurement(nm, sub, predictor, int(m), _data(nm, sub, sd), sd,
                                          fs.metadata.get("path"), dict(fs.metadata)))
    return out
