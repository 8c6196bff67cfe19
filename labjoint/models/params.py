"""Model parameters: value, bounds, unit and vary flag, named ``<effect>.<param>``.

>>> p = Parameters()
>>> p.add("iwan.K_T", 2e7, lower=0.0, unit="N/m")
>>> p["iwan.K_T"].value
20000000.0
>>> Parameters.from_dict(p.to_dict())["iwan.K_T"].unit
'N/m'
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, MutableMapping
from dataclasses import dataclass
from typing import Any

from labjoint.errors import InputError

INF = math.inf


def _bound_out(x: float) -> float | None:
    """JSON-safe bound: infinities become None."""
    return None if math.isinf(x) else float(x)


def _bound_in(x: Any, default: float) -> float:
    return default if x is None else float(x)


@dataclass
class Parameter:
    """One parameter: ``value`` in ``unit`` (SI), kept within [lower, upper] when fitted.

    ``vary`` False holds it fixed during a fit; ``stderr`` is set by a fit.
    """

    name: str
    value: float = math.nan
    lower: float = -INF
    upper: float = INF
    unit: str = ""
    vary: bool = True
    stderr: float | None = None

    def check(self) -> None:
        """Raise InputError when the value is missing, not finite or out of bounds."""
        if not (self.lower <= self.upper):
            raise InputError(f"lower bound {self.lower} > upper bound {self.upper}", field=self.name)
        if not math.isfinite(self.value):
            raise InputError(f"value is {self.value}; give a finite value", field=self.name)
        if not (self.lower <= self.value <= self.upper):
            raise InputError(f"value {self.value:g} {self.unit} outside bounds "
                             f"[{self.lower:g}, {self.upper:g}]", field=self.name)

    def to_dict(self) -> dict[str, Any]:
        return {"value": float(self.value), "lower": _bound_out(self.lower),
                "upper": _bound_out(self.upper), "unit": self.unit, "vary": bool(self.vary),
                "stderr": None if self.stderr is None else float(self.stderr)}

    @classmethod
    def from_dict(cls, name: str, d: Mapping[str, Any]) -> Parameter:
        try:
            return cls(name=name, value=float(d["value"]), lower=_bound_in(d.get("lower"), -INF),
                       upper=_bound_in(d.get("upper"), INF), unit=str(d.get("unit", "")),
                       vary=bool(d.get("vary", True)),
                       stderr=None if d.get("stderr") is None else float(d["stderr"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"bad parameter entry {dict(d)!r}: {exc}", field=name) from None


class Parameters(MutableMapping[str, Parameter]):
    """Ordered mapping name -> :class:`Parameter` (lmfit-like, no fitting logic)."""

    def __init__(self, items: Mapping[str, Parameter] | None = None) -> None:
        self._p: dict[str, Parameter] = {}
        for k, v in (items or {}).items():
            self[k] = v

    def add(self, name: str, value: float = math.nan, *, lower: float = -INF, upper: float = INF,
            unit: str = "", vary: bool = True) -> None:
        """Add or replace parameter ``name``."""
        self._p[name] = Parameter(name, float(value), float(lower), float(upper), unit, vary)

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._p[name]
        except KeyError:
            raise InputError(f"unknown parameter; known: {', '.join(self._p) or 'none'}",
                             field=name) from None

    def __contains__(self, name: object) -> bool:
        return name in self._p

    def __setitem__(self, name: str, p: Parameter) -> None:
        if not isinstance(p, Parameter):
            raise InputError("expected a Parameter", field=name)
        p.name = name
        self._p[name] = p

    def __delitem__(self, name: str) -> None:
        del self._p[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._p)

    def __len__(self) -> int:
        return len(self._p)

    def __repr__(self) -> str:
        body = ", ".join(f"{k}={p.value:.4g}{'' if p.vary else ' (fixed)'}" for k, p in self._p.items())
        return f"Parameters({body})"

    def valuesdict(self) -> dict[str, float]:
        """name -> value."""
        return {k: p.value for k, p in self._p.items()}

    def set(self, name: str, value: float | None = None, *, vary: bool | None = None,
            lower: float | None = None, upper: float | None = None) -> None:
        """Change a parameter's value, vary flag or bounds."""
        p = self[name]
        if value is not None:
            p.value = float(value)
        if vary is not None:
            p.vary = bool(vary)
        if lower is not None:
            p.lower = float(lower)
        if upper is not None:
            p.upper = float(upper)

    def update_values(self, values: Mapping[str, float]) -> None:
        """Set the values of the named parameters (unknown names raise InputError)."""
        for k, v in values.items():
            self[k].value = float(v)

    def check(self) -> None:
        """Check every parameter (finite, within bounds)."""
        for p in self._p.values():
            p.check()

    def copy(self) -> Parameters:
        return Parameters({k: Parameter(**vars(p)) for k, p in self._p.items()})

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """JSON-safe: name -> {value, lower, upper, unit, vary, stderr} (inf bounds -> None)."""
        return {k: p.to_dict() for k, p in self._p.items()}

    @classmethod
    def from_dict(cls, d: Mapping[str, Mapping[str, Any]]) -> Parameters:
        if not isinstance(d, Mapping):
            raise InputError("parameters must be a mapping name -> {value, ...}", field="params")
        out = cls()
        for k, v in d.items():
            if isinstance(v, (int, float)):
                v = {"value": v}
            out[k] = Parameter.from_dict(k, v)
        return out
