"""The plan registry: every plan by name, the parameter types plans share, and the
decorator that registers a plan and validates its arguments when it is called."""

from __future__ import annotations

import functools
from typing import Annotated, Any, Callable, Generator

from pydantic import Field, ValidationError, validate_call

from labjoint.acquisition.messages import Message, WaitSteady
from labjoint.errors import InputError

Plan = Generator[Message, Any, None]

Hz = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Vpp = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Nm = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Newton = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Volt = Annotated[float, Field(allow_inf_nan=False)]
Cycles = Annotated[int, Field(gt=0)]
Window = Annotated[int, Field(ge=2)]
Fraction = Annotated[float, Field(gt=0, lt=1)]

#: Every plan by name (what ``load_plan`` accepts as ``plan = "..."``).
PLANS: dict[str, Callable[..., Plan]] = {}



def register(check: Callable[..., None] | None = None):
    """Register a plan; validate its arguments eagerly (pydantic), then ``check`` them."""

    def deco(fn: Callable[..., Plan]) -> Callable[..., Plan]:
        validated = validate_call(fn)

        @functools.wraps(fn)
        def wrapper(*args: Any, **kwargs: Any) -> Plan:
            try:
                gen = validated(*args, **kwargs)
            except ValidationError as exc:
                raise input_error(exc, fn) from None
            if check is not None:
                check(*args, **kwargs)
            return gen

        PLANS[fn.__name__] = wrapper
        return wrapper

    return deco


def input_error(exc: ValidationError, fn: Callable) -> InputError:
    err = exc.errors()[0]
    loc = list(err["loc"])
    params = [p for p in fn.__code__.co_varnames[: fn.__code__.co_argcount]]
    if loc and isinstance(loc[0], int) and loc[0] < len(params):
        loc[0] = params[loc[0]]
    name = str(loc[0]) if loc else fn.__name__
    name += "".join(f"[{x}]" for x in loc[1:])
    return InputError(f"{fn.__name__}: {err['msg']}", field=name)


def tag(x: float) -> str:
    """A number as a run-name fragment: 12.5 -> '12p5'."""
    return format(float(x), "g").replace(".", "p")


def wait(max_cycles: int, tol: float, window: int) -> WaitSteady:
    return WaitSteady(max_cycles=max_cycles, tol=tol, window=window)
