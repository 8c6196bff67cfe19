"""A joint model: a sum of vocabulary effects written ``a+b+c`` (design.md).

Parameters are named ``<effect>.<param>`` (``iwan.K_T``). Evaluation order: input
effects transform the displacement history (channel_delay first, then backlash), modifier
effects set the slip-strength scaling, hysteretic effects are simulated along the
transformed history (relaxed at its first sample), elastic (memoryless) and force effects
add their terms; the sum is returned on the record samples.

>>> m = Model.parse("linear_stiffness + viscous")
>>> m.expr, m.param_names
('linear_stiffness+viscous', ('linear_stiffness.k', 'viscous.c'))
>>> (m + "coulomb").expr
'linear_stiffness+viscous+coulomb'
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.models.effects import REGISTRY, get_effect
from labjoint.models.effects.base import (
    NO_MODIFIERS,
    Effect,
    ElasticEffect,
    ForceEffect,
    HystereticEffect,
    InputEffect,
    ModifierEffect,
    SlipModifiers,
)
from labjoint.models.inputs import ModelInputs, RunData
from labjoint.models.params import Parameters
from labjoint.models.summary import LoopSummary
from labjoint.vocabulary import EFFECTS

PICARD_MAX = 100
PICARD_TOL = 1e-10
#: Hysteretic force histories a model keeps for reuse (:meth:`Model._simulated`): one per
#: effect and run of a fitted set.
HISTORY_CACHE = 256


def _inputs(x: ModelInputs | RunData) -> ModelInputs:
    if isinstance(x, RunData):
        return x.inputs
    if isinstance(x, ModelInputs):
        return x
    raise InputError(f"expected ModelInputs or RunData, got {type(x).__name__}", field="inputs")


class Model:
    """Sum of distinct vocabulary effects; see the module docstring."""

    def __init__(self, effects: Sequence[Effect]) -> None:
        names = [e.name for e in effects]
        if not names:
            raise InputError(f"empty model; combine effects of: {', '.join(EFFECTS)}", field="model")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"effect(s) {', '.join(dup)} appear more than once; each effect "
                             "may be used once (parameters would collide)", field="model")
        kinds = {e.kind for e in effects}
        if "modifier" in kinds and "hysteretic" not in kinds:
            mods = [e.name for e in effects if e.kind == "modifier"]
            hyst = [n for n, s in EFFECTS.items() if s.kind == "hysteretic"]
            raise InputError(f"{', '.join(mods)} scale(s) the slip strengths of the model's "
                             f"hysteretic part, but the model has none; add one of: "
                             f"{', '.join(hyst)}", field="model")
        if not kinds & {"force", "elastic", "hysteretic"}:
            raise InputError("the model has no force-producing effect (force, elastic or "
                             "hysteretic)",
                             field="model")
        self.effects: tuple[Effect, ...] = tuple(effects)

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def parse(cls, expr: str | Model) -> Model:
        """Model from ``"a+b+c"``; unknown names raise InputError listing the vocabulary."""
        if isinstance(expr, Model):
            return expr
        if not isinstance(expr, str):
            raise InputError(f"model must be a string like 'linear_stiffness+iwan', got {expr!r}",
                             field="model")
        terms = [t.strip().lower() for t in expr.split("+")]
        if any(not t for t in terms):
            raise InputError(f"empty term in '{expr}'; write effects as a+b+c", field="model")
        return cls([get_effect(t) for t in terms])

    def __add__(self, other: Model | str) -> Model:
        other = Model.parse(other)
        return Model(self.effects + tuple(get_effect(e.name) for e in other.effects))

    def __radd__(self, other: str) -> Model:
        return Model.parse(other) + self

    def __repr__(self) -> str:
        return f"Model('{self.expr}')"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Model) and self.expr == other.expr

    def __hash__(self) -> int:
        return hash(self.expr)

    @property
    def expr(self) -> str:
        return "+".join(e.name for e in self.effects)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.effects)

    def effect(self, name: str) -> Effect:
        for e in self.effects:
            if e.name == name:
                return e
        raise InputError(f"effect not in model '{self.expr}'", field=name)

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(f"{e.name}.{p.name}" for e in self.effects for p in e.params)

    def of_kind(self, kind: str) -> tuple[Effect, ...]:
        return tuple(e for e in self.effects if e.kind == kind)

    # -- parameters -----------------------------------------------------------------------
    def make_params(self, values: Mapping[str, float] | None = None,
                    runs: Sequence[RunData] | LoopSummary | None = None) -> Parameters:
        """Parameters with vocabulary bounds and units: initial guesses from ``runs`` (loop
        quantities) if given, then ``values`` (``"<effect>.<param>": value``) on top."""
        summary = None
        if runs is not None:
            summary = runs if isinstance(runs, LoopSummary) else LoopSummary.from_runs(runs)
        out = Parameters()
        for e in self.effects:
            g = e.guess(summary) if summary is not None else {}
            for p in e.params:
                v = g.get(p.name, np.nan)
                v = float(np.clip(v, p.lower, p.upper)) if np.isfinite(v) else np.nan
                out.add(f"{e.name}.{p.name}", v, lower=p.lower, upper=p.upper, unit=p.unit)
        for k, v in (values or {}).items():
            if k not in out:
                raise InputError(f"not a parameter of '{self.expr}'; known: "
                                 f"{', '.join(self.param_names)}", field=k)
            out[k].value = float(v.value if hasattr(v, "value") else v)
        return out

    def values(self, params: Parameters | Mapping[str, Any]) -> dict[str, dict[str, float]]:
        """effect -> {param: value}, checked against the vocabulary bounds."""
        flat: dict[str, float] = {}
        for k, v in params.items():
            flat[k] = float(v.value if hasattr(v, "value") else v)
        out: dict[str, dict[str, float]] = {}
        for e in self.effects:
            d = {}
            for p in e.params:
                key = f"{e.name}.{p.name}"
                if key not in flat:
                    raise InputError(f"missing value for model '{self.expr}'", field=key)
                d[p.name] = flat[key]
            e.check(d)
            out[e.name] = d
        return out

    # -- evaluation -----------------------------------------------------------------------
    def _prepare(self, vals: Mapping[str, Mapping[str, float]],
                 inputs: ModelInputs) -> tuple[ModelInputs, SlipModifiers]:
        x = inputs
        for e in sorted(self.of_kind("input"), key=lambda e: e.order):  # type: ignore[attr-defined]
            assert isinstance(e, InputEffect)
            x = e.transform(vals[e.name], x)
        mods = NO_MODIFIERS
        for e in self.of_kind("modifier"):
            assert isinstance(e, ModifierEffect)
            mods = e.modify(vals[e.name], mods)
        return x, mods

    def _hysteretic(self, vals: Mapping[str, Mapping[str, float]], x: ModelInputs,
                    mods: SlipModifiers) -> dict[str, np.ndarray]:
        """Force histories of the hysteretic effects; with wear shared by several of them
        the joint's total dissipation couples them, solved by Picard iteration (causal,
        so it converges)."""
        hyst = [e for e in self.effects if isinstance(e, HystereticEffect)]
        u = x.u_hist
        if len(hyst) <= 1 or mods.inv_ew == 0.0:
            return {e.name: self._simulated(e, vals[e.name], u, mods) for e in hyst}
        energies = {e.name: np.zeros_like(u) for e in hyst}
        forces = {e.name: np.zeros_like(u) for e in hyst}
        for _ in range(PICARD_MAX):
            total = sum(energies.values())
            change = 0.0
            new_e = {}
            for e in hyst:
                f, ed = e.simulate(vals[e.name], u, mods, total - energies[e.name])
                scale = max(float(np.max(np.abs(f))), 1e-300)
                change = max(change, float(np.max(np.abs(f - forces[e.name]))) / scale)
                forces[e.name], new_e[e.name] = f, ed
            energies = new_e
            if change < PICARD_TOL:
                break
        return forces

    def _simulated(self, e: HystereticEffect, vals: Mapping[str, float], u: np.ndarray,
                   mods: SlipModifiers) -> np.ndarray:
        """``e``'s force history along ``u``, reused while its parameters, the modifiers
        and the history array are the same: a fit's finite-difference Jacobian moves one
        parameter at a time, so every other effect's history is the one already computed
        (the effects are independent here: no wear couples them). Kept per history array
        (a run; its values compared, a few microseconds against a simulation's
        milliseconds), at most :data:`HISTORY_CACHE` of them; read-only, never changed."""
        key = (e.name, id(u))
        p = tuple(vals.values())
        cache = self.__dict__.setdefault("_history_cache", {})
        hit = cache.get(key)
        if hit is not None and hit[1] == mods and hit[2] == p and np.array_equal(hit[0], u):
            return hit[3]
        f = e.simulate(vals, u, mods)[0]
        f.flags.writeable = False
        if len(cache) >= HISTORY_CACHE:
            cache.clear()
        cache[key] = (u.copy(), mods, p, f)     # a copy: ``u`` compared by value, so a
        return f                                # buffer refilled in place is never stale

    def __getstate__(self) -> dict[str, Any]:
        """Pickled (to a worker, in a fit result) without the cached histories."""
        state = dict(self.__dict__)
        state.pop("_history_cache", None)
        return state

    def _histories(self, vals: Mapping[str, Mapping[str, float]], inputs: ModelInputs,
                   solve: frozenset[str] = frozenset()
                   ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Force history per effect, and the regressors (``basis``) of the force effects in
        ``solve`` instead of their forces."""
        x, mods = self._prepare(vals, inputs)
        forces = self._hysteretic(vals, x, mods)
        bases = {}
        for e in self.effects:
            if isinstance(e, ElasticEffect):
                forces[e.name] = e.elastic(vals[e.name], x.u_hist)
            elif isinstance(e, ForceEffect):
                b = e.basis(x)
                if e.name in solve:
                    bases[e.name] = b
                else:
                    forces[e.name] = vals[e.name][e.param_names[0]] * b
        return forces, bases

    def eval(self, params: Parameters | Mapping[str, Any], inputs: ModelInputs | RunData) -> np.ndarray:
        """Model force (N) on the record samples of ``inputs``."""
        inp = _inputs(inputs)
        forces, _ = self._histories(self.values(params), inp)
        total = np.zeros(len(inp))
        for f in forces.values():
            total += f[inp.n_prime:]
        return total

    def eval_components(self, params: Parameters | Mapping[str, Any],
                        inputs: ModelInputs | RunData) -> dict[str, np.ndarray]:
        """effect -> its force term (N) on the record samples; they sum to :meth:`eval`.
        Hysteretic terms include the modifiers' scaling and every term sees the input
        effects' transformed history; modifier and input effects report zero."""
        inp = _inputs(inputs)
        forces, _ = self._histories(self.values(params), inp)
        return {e.name: forces[e.name][inp.n_prime:] if e.name in forces else np.zeros(len(inp))
                for e in self.effects}

    def eval_split(self, params: Parameters | Mapping[str, Any], inputs: ModelInputs | RunData,
                   solve: Sequence[str]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """For variable projection: the force of every term except the force effects in
        ``solve``, and those effects' regressors (force per unit parameter), on the record
        samples. Parameters of the ``solve`` effects may hold any in-bounds value."""
        inp = _inputs(inputs)
        forces, bases = self._histories(self.values(params), inp, frozenset(solve))
        rest = np.zeros(len(inp))
        for f in forces.values():
            rest += f[inp.n_prime:]
        return rest, {k: b[inp.n_prime:] for k, b in bases.items()}

    # -- serialisation --------------------------------------------------------------------
    def to_dict(self, params: Parameters | None = None) -> dict[str, Any]:
        """JSON-safe: registry names and, if given, the parameters (never code)."""
        d: dict[str, Any] = {"model": self.expr, "effects": list(self.names)}
        if params is not None:
            missing = [k for k in self.param_names if k not in params]
            if missing:
                raise InputError(f"parameters lack {', '.join(missing)}", field="params")
            d["params"] = {k: params[k].to_dict() for k in self.param_names}
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> tuple[Model, Parameters | None]:
        """Inverse of :meth:`to_dict`: (model, parameters or None)."""
        if not isinstance(d, Mapping) or ("effects" not in d and "model" not in d):
            raise InputError("expected a mapping with 'effects' (or 'model')", field="model")
        model = cls([get_effect(n) for n in d["effects"]]) if "effects" in d else cls.parse(d["model"])
        params = None
        if d.get("params") is not None:
            params = Parameters.from_dict(d["params"])
            unknown = set(params) - set(model.param_names)
            missing = set(model.param_names) - set(params)
            if unknown or missing:
                raise InputError(f"parameters do not match model '{model.expr}': unknown "
                                 f"{sorted(unknown)}, missing {sorted(missing)}", field="params")
        return model, params


assert set(REGISTRY) == set(EFFECTS)
