"""Base classes of the joint-model effects (abc-enforced), one family per vocabulary kind.

Every concrete effect names a vocabulary entry (``name``); its ``kind`` and ``params``
(names, units, bounds) come from :mod:`labjoint.vocabulary`, never from the subclass.
It must give a one-paragraph physical ``description``, the ``signature`` it leaves in
data, initial guesses from data (``guess``) and its force along a displacement history.

Families:

- :class:`ForceEffect` (kind "force"): force = parameter x a regressor built from the
  history (``basis``); all vocabulary force terms are linear in their one parameter, so
  fits solve them exactly (variable projection).
- :class:`ElasticEffect` (kind "elastic"): a memoryless force F = f(u; params), nonlinear
  in some parameter (a contact's gap), evaluated on whole arrays at once (any shape: the
  structure's harmonic balance passes a batch of histories).
- :class:`HystereticEffect` (kind "hysteretic"): history-dependent force, simulated
  sample by sample from a relaxed state at the first sample (numba kernels).
- :class:`ModifierEffect` (kind "modifier"): scales the slip strengths of the model's
  hysteretic part (:class:`SlipModifiers`); adds no force itself.
- :class:`InputEffect` (kind "input"): transforms the displacement history the other
  effects see; adds no force itself.
"""

from __future__ import annotations

import abc
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from labjoint.errors import InputError
from labjoint.vocabulary import EFFECTS, EffectSpec, ParamSpec

if TYPE_CHECKING:
    from labjoint.models.inputs import ModelInputs
    from labjoint.models.summary import LoopSummary


@dataclass(frozen=True)
class SlipModifiers:
    """Slip-strength scaling applied by modifier effects to every hysteretic effect.

    Slip strengths are scaled by (1 + asym) while sliding in +u and (1 - asym) in -u
    (asymmetric_slip), and by exp(-E_d / E_w) with E_d the joint's friction energy
    dissipated since the history began (wear; ``inv_ew`` = 1 / E_w, 0 = no wear).
    """

    asym: float = 0.0
    inv_ew: float = 0.0

    @property
    def active(self) -> bool:
        return self.asym != 0.0 or self.inv_ew != 0.0


NO_MODIFIERS = SlipModifiers()


class Effect(abc.ABC):
    """One named physical effect of the vocabulary (see module docstring)."""

    name: ClassVar[str]
    description: ClassVar[str]
    signature: ClassVar[str]
    spec: ClassVar[EffectSpec]
    #: parameters fitted as log(p) (strictly positive scale parameters)
    log_params: ClassVar[frozenset[str]] = frozenset()
    #: True when the fit surface of this effect's parameters is known to be multimodal
    needs_multistart: ClassVar[bool] = False
    _family: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        if "name" not in cls.__dict__:
            return  # a family base, not a concrete effect
        spec = EFFECTS.get(cls.name)
        if spec is None:
            raise TypeError(f"{cls.__name__}: '{cls.name}' is not in the vocabulary")
        if spec.kind != cls._family:
            raise TypeError(f"{cls.__name__}: vocabulary kind of '{cls.name}' is '{spec.kind}', "
                            f"but the class derives from the '{cls._family}' family")
        for attr in ("description", "signature"):
            text = cls.__dict__.get(attr)
            if not isinstance(text, str) or len(text.split()) < 5:
                raise TypeError(f"{cls.__name__}: needs a written '{attr}'")
        unknown = set(cls.log_params) - {p.name for p in spec.params}
        if unknown:
            raise TypeError(f"{cls.__name__}: log_params {sorted(unknown)} are not parameters")
        cls.spec = spec

    # -- vocabulary-derived ---------------------------------------------------------------
    @property
    def kind(self) -> str:
        return self.spec.kind

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return self.spec.params

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.spec.params)

    def __repr__(self) -> str:
        return f"<effect {self.name}>"

    def check(self, values: Mapping[str, float]) -> None:
        """Raise InputError naming ``<effect>.<param>`` if a value is missing or out of bounds."""
        for p in self.spec.params:
            key = f"{self.name}.{p.name}"
            if p.name not in values:
                raise InputError("missing value", field=key)
            x = float(values[p.name])
            if not np.isfinite(x) or not (p.lower <= x <= p.upper):
                raise InputError(f"value {x:g} {p.unit} outside [{p.lower:g}, {p.upper:g}]", field=key)

    # -- behaviour ------------------------------------------------------------------------
    @abc.abstractmethod
    def guess(self, summary: LoopSummary) -> dict[str, float]:
        """Initial parameter values (unprefixed names) from the data's loop quantities."""

    @abc.abstractmethod
    def force(self, params: Mapping[str, float], inputs: ModelInputs,
              modifiers: SlipModifiers = NO_MODIFIERS) -> np.ndarray:
        """This effect's force (N) on the record samples of ``inputs``."""

    def neutral(self, summary: LoopSummary) -> dict[str, float] | None:
        """Parameter values at which the effect changes nothing (None if it has none, or
        none a fit can start from). A warm-started refit that adds the effect starts
        there, so it can only improve on the previous fit."""
        return None

    def steady_term(self, params: Mapping[str, float]) -> tuple[int, np.ndarray] | None:
        """This effect (without modifiers) as a term of the batched steady-state kernel
        (:mod:`labjoint.models.effects._steady`): (code, parameter vector) giving the same
        force as :meth:`force`, or None if the effect has no such term."""
        return None

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        """Typical magnitude of each parameter (used to scale the fit to order one)."""
        out = {}
        for p in self.spec.params:
            g = abs(float(guess[p.name]))
            span = p.upper - p.lower
            out[p.name] = g if g > 0 else (span / 4 if np.isfinite(span) else 1.0)
        return out


class ForceEffect(Effect):
    """Force = parameter x ``basis(history)``: linear in its single parameter."""

    _family = "force"
    #: the term of the steady-state kernel: force = parameter x this code's regressor
    steady_code: ClassVar[int | None] = None

    def steady_term(self, params: Mapping[str, float]) -> tuple[int, np.ndarray] | None:
        if self.steady_code is None:
            return None
        return self.steady_code, np.array([float(params[self.param_names[0]])])

    @abc.abstractmethod
    def basis(self, inputs: ModelInputs) -> np.ndarray:
        """Force per unit parameter along the whole history (priming included)."""

    def force(self, params: Mapping[str, float], inputs: ModelInputs,
              modifiers: SlipModifiers = NO_MODIFIERS) -> np.ndarray:
        (p,) = self.param_names
        return float(params[p]) * self.basis(inputs)[inputs.n_prime:]


class ElasticEffect(Effect):
    """Memoryless force F = f(u; params), nonlinear in its parameters."""

    _family = "elastic"

    @abc.abstractmethod
    def elastic(self, params: Mapping[str, float], u: np.ndarray) -> np.ndarray:
        """Force (N) at displacements ``u`` (m), elementwise (any shape)."""

    def force(self, params: Mapping[str, float], inputs: ModelInputs,
              modifiers: SlipModifiers = NO_MODIFIERS) -> np.ndarray:
        return self.elastic(params, inputs.u_hist)[inputs.n_prime:]


class HystereticEffect(Effect):
    """History-dependent force, relaxed at the first sample of the history."""

    _family = "hysteretic"
    needs_multistart = True

    @abc.abstractmethod
    def simulate(self, params: Mapping[str, float], u: np.ndarray, modifiers: SlipModifiers,
                 e_other: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and cumulative dissipated energy E_d (J) along history ``u`` (m).

        ``e_other`` is the dissipation of the model's other hysteretic effects (adds to
        E_d for wear); state starts relaxed at ``u[0]``.
        """

    def force(self, params: Mapping[str, float], inputs: ModelInputs,
              modifiers: SlipModifiers = NO_MODIFIERS) -> np.ndarray:
        f, _ = self.simulate(params, inputs.u_hist, modifiers)
        return f[inputs.n_prime:]



class ModifierEffect(Effect):
    """Scales the hysteretic part's slip strengths; contributes no force of its own."""

    _family = "modifier"

    @abc.abstractmethod
    def modify(self, params: Mapping[str, float], mods: SlipModifiers) -> SlipModifiers:
        """``mods`` with this effect's scaling added."""

    def force(self, params: Mapping[str, float], inputs: ModelInputs,
              modifiers: SlipModifiers = NO_MODIFIERS) -> np.ndarray:
        return np.zeros(len(inputs))


class InputEffect(Effect):
    """Transforms the displacement history; contributes no force of its own."""

    _family = "input"
    #: application order (lower first): a delay acts on everything, a gap on the joint
    order: ClassVar[int] = 0

    @abc.abstractmethod
    def transform(self, params: Mapping[str, float], inputs: ModelInputs) -> ModelInputs:
        """Inputs as the joint sees them."""

    def force(self, params: Mapping[str, float], inputs: ModelInputs,
              modifiers: SlipModifiers = NO_MODIFIERS) -> np.ndarray:
        return np.zeros(len(inputs))
