"""Parse the simulated joint's law and injected effects (names and laws: labjoint.vocabulary).

Where each effect acts in the simulated rig:

- hysteretic (``coulomb``, ``iwan``, ``bouc_wen``, ``valanis``, ``richard_abbott``): as
  ``joint`` it replaces the contact rings; as an effect it adds an element in parallel.
- ``linear_stiffness``, ``cubic_stiffness``, ``viscous``: added to the joint force that
  acts on the beams, so they change the dynamics.
- ``offset``: a tangential preload locked into the assembly: the joint carries F0 and the
  beam supports hold the reaction, so the joint force gains F0 and the motion is unchanged.
- ``inertia``: a mass between the joint-force sensor and the interface; it is part of the
  beams' mass, and the sensor reads F_joint + m d2u/dt2.
- ``channel_delay``: the force channels lag the displacement channels by tau (tau < 0
  delays the displacement channels instead).
- ``backlash``: dead zone before the contact: elastic and hysteretic parts see u_eff.
- ``wear``, ``asymmetric_slip``: scale the slip strengths of every hysteretic element.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from labjoint.errors import ConfigError
from labjoint.vocabulary import EFFECTS, HYSTERETIC

#: Parameters that must be strictly positive for the law to be defined (vocabulary bounds are inclusive).
#: Named contact joints (the rings of [sim.contact]) -> whether a shear layer sits in series:
#: ``seed002`` (default) adds the viscoelastic layer that makes the joint dissipate like
#: seed 002's (Tables 2-4); ``dry_microslip`` (alias ``contact``) is the dry contact alone.
PRESETS = {"seed002": True, "dry_microslip": False, "contact": False}
STRICT = {"coulomb": ("k", "f_s"), "iwan": ("F_S", "K_T"), "bouc_wen": ("k0",),
          "valanis": ("E0",), "richard_abbott": ("ke", "F_y"), "wear": ("E_w",)}


@dataclass(frozen=True)
class JointSpec:
    """The simulated joint: primary law, extra hysteretic elements, and effect parameters (SI)."""

    family: str = "contact"                        # "contact", "none" or a hysteretic name
    params: dict[str, float] = field(default_factory=dict)
    hysteretic: tuple[tuple[str, dict[str, float]], ...] = ()
    k_lin: float = 0.0
    k3: float = 0.0
    c: float = 0.0
    f0: float = 0.0
    inertia_m: float = 0.0
    asym: float = 0.0
    wear_e_w: float = math.inf
    gap: float = 0.0
    tau: float = 0.0
    names: tuple[str, ...] = ()
    layer: bool = False                            # seed002: shear layer in series

    @property
    def has_contact(self) -> bool:
        return self.family == "contact"


def _params(name: str, table: dict[str, Any], where: str) -> dict[str, float]:
    spec = EFFECTS[name]
    known = [p.name for p in spec.params]
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ConfigError(f"unknown parameter(s) {unknown} for {name!r}; expected {known}", field=f"{where}.{unknown[0]}")
    out: dict[str, float] = {}
    for p in spec.params:
        if p.name not in table:
            raise ConfigError(f"{name!r} needs parameter {p.name!r} ({p.unit}: {p.description})", field=f"{where}.{p.name}")
        v = table[p.name]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ConfigError(f"must be a finite number ({p.unit}), got {v!r}", field=f"{where}.{p.name}")
        if not p.lower <= v <= p.upper:
            raise ConfigError(f"must be within [{p.lower}, {p.upper}] {p.unit}, got {v!r}", field=f"{where}.{p.name}")
        if p.name in STRICT.get(name, ()) and not v > 0:
            raise ConfigError(f"must be positive ({p.unit}), got {v!r}", field=f"{where}.{p.name}")
        out[p.name] = float(v)
    return out


def _split(table: Any, key: str, where: str) -> tuple[str, dict[str, Any]]:
    if not isinstance(table, dict):
        raise ConfigError(f"must be a table with {key!r} and the law's parameters, got {table!r}", field=where)
    rest = dict(table)
    name = rest.pop(key, None)
    if not isinstance(name, str):
        raise ConfigError(f"missing {key!r} (one of {sorted(EFFECTS)})", field=f"{where}.{key}")
    return name, rest


def parse_joint(joint: str | dict[str, Any], effects: list[dict[str, Any]]) -> JointSpec:
    """Validate ``[sim] joint`` and ``[sim] effects``; raise ConfigError naming the field.

    >>> parse_joint("contact", [{"name": "viscous", "c": 10.0}]).c
    10.0
    >>> parse_joint({"family": "coulomb", "k": 1e7, "f_s": 50.0}, []).family
    'coulomb'
    >>> parse_joint("seed002", []).layer, parse_joint("dry_microslip", []).layer
    (True, False)
    """
    choices = f"use {list(PRESETS)}, 'none' or one of {list(HYSTERETIC)}"
    if isinstance(joint, str):
        family, raw, where = joint, {}, "sim.joint"
    else:
        family, raw = _split(joint, "family", "sim.joint")
        where = "sim.joint.family"
    layer = PRESETS.get(family, False)
    if family in PRESETS:
        family = "contact"
    if family in ("contact", "none"):
        if raw:
            raise ConfigError(f"joint {family!r} takes no parameters here (the contact's are in [sim.contact])",
                              field=f"sim.joint.{sorted(raw)[0]}")
        params: dict[str, float] = {}
    elif family in HYSTERETIC:
        if isinstance(joint, str):
            raise ConfigError(f"family {family!r} needs its parameters: joint = {{family = {family!r}, ...}}",
                              field="sim.joint")
        params = _params(family, raw, "sim.joint")
    else:
        raise ConfigError(f"unknown joint family {family!r}; {choices}", field=where)
    acc: dict[str, Any] = dict(k_lin=0.0, k3=0.0, c=0.0, f0=0.0, inertia_m=0.0, asym=0.0,
                               wear_e_w=math.inf, gap=0.0, tau=0.0)
    hyst: list[tuple[str, dict[str, float]]] = []
    seen: set[str] = set()
    names: list[str] = []
    if not isinstance(effects, list):
        raise ConfigError("must be a list of tables {name = ..., <params>}", field="sim.effects")
    for i, table in enumerate(effects):
        where = f"sim.effects[{i}]"
        name, raw = _split(table, "name", where)
        if name not in EFFECTS:
            raise ConfigError(f"unknown effect {name!r}; known: {sorted(EFFECTS)}", field=f"{where}.name")
        p = _params(name, raw, where)
        kind = EFFECTS[name].kind
        if kind in ("modifier", "input") and name in seen:
            raise ConfigError(f"effect {name!r} given twice", field=f"{where}.name")
        seen.add(name)
        names.append(name)
        if kind == "hysteretic":
            hyst.append((name, p))
        elif name == "linear_stiffness":
            acc["k_lin"] += p["k"]
        elif name == "cubic_stiffness":
            acc["k3"] += p["k3"]
        elif name == "viscous":
            acc["c"] += p["c"]
        elif name == "offset":
            acc["f0"] += p["F0"]
        elif name == "inertia":
            acc["inertia_m"] += p["m"]
        elif name == "asymmetric_slip":
            acc["asym"] = p["asym"]
        elif name == "wear":
            acc["wear_e_w"] = p["E_w"]
        elif name == "backlash":
            acc["gap"] = p["gap"]
        elif name == "channel_delay":
            acc["tau"] = p["tau"]
        else:  # pragma: no cover - vocabulary grew without the simulator
            raise ConfigError(f"effect {name!r} is not implemented by the simulator", field=f"{where}.name")
    return JointSpec(family=family, params=params, hysteretic=tuple(hyst), names=tuple(names),
                     layer=layer, **acc)
