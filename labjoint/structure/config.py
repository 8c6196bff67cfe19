"""A structure described in TOML (components, sections, materials, supports, masses, joints,
excitation, sensors, damping) read into an assembled :class:`Structure`.

Every problem raises one :class:`InputError` naming the key (``components.pipe.section``,
``joints.thread.x_m``, ...). Points are given as a component and an axial position
``x_m`` on it; a mesh node is placed at every point. See ``configs/structure-seed000.toml``
for a commented example.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.structure.assembly import Component, Damping, Structure, X_TOL, build
from labjoint.structure.beam import THEORIES
from labjoint.structure.joint import Layer, layer_params, layer_transverse_stiffness
from labjoint.structure.law import JointLaw
from labjoint.structure.sections import SECTION_KEYS, GeneralSection, HollowCircle, Material, Rectangle
from labjoint.tomlfile import read_toml

_MISSING = object()
SUPPORTS = ("clamped", "pinned", "elastic", "free")
LAYER_LAW = ("E_p_pa", "S_Y_pa", "n")


def _num(t: Mapping[str, Any], key: str, where: str, default: Any = _MISSING, positive: bool = False) -> float:
    if key not in t:
        if default is _MISSING:
            raise InputError("missing", field=f"{where}.{key}")
        return default
    v = t[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise InputError(f"must be a number, got {v!r}", field=f"{where}.{key}")
    if positive and v <= 0:
        raise InputError(f"must be > 0, got {v!r}", field=f"{where}.{key}")
    return float(v)


def _str(t: Mapping[str, Any], key: str, where: str, default: Any = _MISSING) -> str:
    if key not in t:
        if default is _MISSING:
            raise InputError("missing", field=f"{where}.{key}")
        return default
    if not isinstance(t[key], str):
        raise InputError(f"must be a string, got {t[key]!r}", field=f"{where}.{key}")
    return t[key]


def _table(d: Mapping[str, Any], key: str, where: str = "", required: bool = True) -> dict:
    full = f"{where}.{key}" if where else key
    if key not in d:
        if required:
            raise InputError("missing table", field=full)
        return {}
    if not isinstance(d[key], Mapping):
        raise InputError("must be a table", field=full)
    return dict(d[key])


def _list(d: Mapping[str, Any], key: str) -> list[dict]:
    v = d.get(key, [])
    if not isinstance(v, list) or not all(isinstance(x, Mapping) for x in v):
        raise InputError("must be an array of tables ([[...]])", field=key)
    return [dict(x) for x in v]


def _point(t: Mapping[str, Any], where: str, comps: dict[str, Component],
           key: str = "component") -> tuple[str, float]:
    c = _str(t, key, where)
    if c not in comps:
        raise InputError(f"no component '{c}'; components: {', '.join(comps)}", field=f"{where}.{key}")
    x = _num(t, "x_m", where)
    comp = comps[c]
    if not (comp.x_start_m - X_TOL <= x <= comp.x_end_m + X_TOL):
        raise InputError(f"{x:g} m is off component '{c}' (it spans {comp.x_start_m:g} to "
                         f"{comp.x_end_m:g} m)", field=f"{where}.x_m")
    return c, float(np.clip(x, comp.x_start_m, comp.x_end_m))


#: Beam elements a structure file may ask for (seed 000's assembly needs about 80).
MAX_ELEMENTS = 2000


def structure_from_dict(d: Mapping[str, Any]) -> Structure:
    """Validate and assemble a structure description (module docstring)."""
    head = _table(d, "structure", required=False)
    name = _str(head, "name", "structure", "structure")
    theory = _str(head, "beam", "structure", "timoshenko")
    if theory not in THEORIES:
        raise InputError(f"must be one of {', '.join(THEORIES)}, got '{theory}'", field="structure.beam")
    el = _num(head, "element_length_m", "structure", 0.02, positive=True)
    mats = {k: Material(_num(v, "E_pa", f"materials.{k}"), _num(v, "rho_kg_m3", f"materials.{k}"),
                        _num(v, "nu", f"materials.{k}", 0.3), name=k)
            for k, v in _table(d, "materials").items()}
    secs = {k: _section(k, v) for k, v in _table(d, "sections").items()}
    comps: dict[str, Component] = {}
    for k, v in _table(d, "components").items():
        w = f"components.{k}"
        s, m = _str(v, "section", w), _str(v, "material", w)
        if s not in secs:
            raise InputError(f"no section '{s}'; sections: {', '.join(secs) or 'none'}", field=f"{w}.section")
        if m not in mats:
            raise InputError(f"no material '{m}'; materials: {', '.join(mats) or 'none'}", field=f"{w}.material")
        comps[k] = Component(k, secs[s], mats[m], _num(v, "x_start_m", w, 0.0),
                             _num(v, "length_m", w, positive=True))
    if not comps:
        raise InputError("no components", field="components")
    n_el = sum(int(np.ceil(c.length_m / el)) for c in comps.values())
    if n_el > MAX_ELEMENTS:            # the matrices are dense: refuse before allocating
        raise InputError(f"{el:g} m elements make {n_el} beam elements; at most {MAX_ELEMENTS}",
                         field="structure.element_length_m")
    points: dict[str, list[float]] = {k: [] for k in comps}

    def at(t: Mapping[str, Any], where: str, key: str = "component") -> tuple[str, float]:
        p = _point(t, where, comps, key)
        points[p[0]].append(p[1])
        return p

    supports = []
    for i, v in enumerate(_list(d, "supports")):
        w = f"supports[{i}]"
        kind = _str(v, "type", w)
        if kind not in SUPPORTS:
            raise InputError(f"must be one of {', '.join(SUPPORTS)}, got '{kind}'", field=f"{w}.type")
        c, x = at(v, w)
        supports.append((c, x, kind, _num(v, "k_w_n_per_m", w, 0.0), _num(v, "k_theta_nm_per_rad", w, 0.0)))
    masses = []
    for i, v in enumerate(_list(d, "masses")):
        w = f"masses.{v.get('name', i)}"
        c, x = at(v, w)
        masses.append((c, x, _num(v, "mass_kg", w, 0.0), _num(v, "inertia_kg_m2", w, 0.0)))
    joints = [_joint(v, at, comps) for v in _list(d, "joints")]
    _connected(comps, joints)
    ext = _table(d, "excitation")
    ex = at(ext, "excitation")
    moving = _num(ext, "moving_mass_kg", "excitation", 0.0)
    if moving < 0:
        raise InputError(f"must be >= 0 kg, got {moving:g}", field="excitation.moving_mass_kg")
    if moving > 0:            # the shaker's armature, stinger and fixture move with the point
        masses.append((ex[0], ex[1], moving, 0.0))
    sensors = []
    for i, v in enumerate(_list(d, "sensors")):
        nm = _str(v, "name", f"sensors[{i}]")
        sensors.append((nm, *at(v, f"sensors.{nm}")))
    return build(name, theory, list(comps.values()), el, points, supports, masses, joints, ex,
                 sensors, _damping(_table(d, "damping", required=False)))


def _section(k: str, v: Any) -> Any:
    """A ``[sections.NAME]`` table: hollow circle (od_m, wall_m), rectangle (b_m, h_m) or
    general (area_m2, inertia_m4, optional torsion_m4, shear_coefficient), told apart by
    its keys or by ``type``."""
    w = f"sections.{k}"
    if not isinstance(v, Mapping):
        raise InputError("must be a table", field=w)
    kind = _str(v, "type", w, None)
    if kind is None:
        kinds = [n for n, keys in SECTION_KEYS.items() if any(x in v for x in keys)]
        if len(kinds) != 1:
            raise InputError("give one kind of section: " + "; ".join(
                f"{n} ({', '.join(keys)})" for n, keys in SECTION_KEYS.items()), field=w)
        kind = kinds[0]
    if kind not in SECTION_KEYS:
        raise InputError(f"must be one of {', '.join(SECTION_KEYS)}, got '{kind}'", field=f"{w}.type")
    if kind == "hollow_circle":
        return HollowCircle(_num(v, "od_m", w), _num(v, "wall_m", w), name=k)
    if kind == "rectangle":
        return Rectangle(_num(v, "b_m", w), _num(v, "h_m", w), name=k)
    return GeneralSection(_num(v, "area_m2", w), _num(v, "inertia_m4", w), _num(v, "torsion_m4", w, 0.0),
                          _num(v, "shear_coefficient", w, 5.0 / 6.0), name=k)


def _joint(v: Mapping[str, Any], at: Any, comps: Mapping[str, Component]) -> dict:
    nm = _str(v, "name", "joints")
    w = f"joints.{nm}"
    between = v.get("between")
    if not (isinstance(between, list) and len(between) == 2 and all(isinstance(b, str) for b in between)):
        raise InputError("must name two components, e.g. [\"pipe_a\", \"coupling\"]", field=f"{w}.between")
    if between[0] == between[1]:
        raise InputError("a joint connects two different components", field=f"{w}.between")
    kind = _str(v, "type", w, "thread")
    if kind == "lap":
        return _lap_joint(v, nm, between, at, comps)
    if kind != "thread":
        raise InputError(f"must be thread or lap, got '{kind}'", field=f"{w}.type")
    a = at({"component": between[0], "x_m": v.get("x_m")}, w)
    b = at({"component": between[1], "x_m": v.get("x_m")}, w)
    radius = _num(v, "radius_m", w, positive=True)
    lt = _table(v, "layer", w, required=False)
    layer = None
    params = {}
    if lt:
        wl = f"{w}.layer"
        vals = {k: _num(lt, k, wl, None) for k in LAYER_LAW}
        layer = Layer(_num(lt, "length_m", wl, positive=True), _num(lt, "thickness_m", wl, positive=True),
                      _num(lt, "E_e_pa", wl, positive=True), **vals)
        given = [k for k in LAYER_LAW if vals[k] is not None]
        if given and len(given) < 3:
            missing = [k for k in LAYER_LAW if vals[k] is None]
            raise InputError(f"the stress law needs E_p_pa, S_Y_pa and n together", field=f"{wl}.{missing[0]}")
        if given:
            params.update(layer_params(layer, radius))
    model = _str(v, "model", w, "richard_abbott")
    extra = _table(v, "params", w, required=False)
    for k, x in extra.items():
        params[k] = _num(extra, k, f"{w}.params")
    law = JointLaw(model, params, field=w)
    if "transverse_stiffness_n_per_m" in v or layer is None:
        kt = _num(v, "transverse_stiffness_n_per_m", w, positive=True)
    else:
        kt = layer_transverse_stiffness(layer, radius)
    return {"name": nm, "a": a, "b": b, "law": law, "radius_m": radius, "stations": _stations(v, w),
            "transverse_stiffness": kt, "layer": layer}


def _stations(v: Mapping[str, Any], w: str) -> int:
    stations = v.get("stations", 8)
    if isinstance(stations, bool) or not isinstance(stations, int):
        raise InputError(f"must be an even whole number >= 4, got {stations!r}", field=f"{w}.stations")
    return stations


def _lap_joint(v: Mapping[str, Any], nm: str, between: list[str], at: Any,
               comps: Mapping[str, Component]) -> dict:
    """A bolted lap joint (:mod:`labjoint.structure.joint`): the two components must overlap;
    the bolt at ``x_m`` (default: the middle of the overlap) joins them with the translational
    stiffness ``transverse_stiffness_n_per_m`` and the law ``model`` (default
    linear_stiffness, parameters in ``[joints.params]``, N/m of the whole interface) on the
    relative rotation over a contact of ``contact_length_m`` (default: the overlap)."""
    w = f"joints.{nm}"
    ca, cb = comps[between[0]] if between[0] in comps else None, comps.get(between[1])
    for c, name in ((ca, between[0]), (cb, between[1])):
        if c is None:
            raise InputError(f"no component '{name}'; components: {', '.join(comps)}", field=f"{w}.between")
    lo, hi = max(ca.x_start_m, cb.x_start_m), min(ca.x_end_m, cb.x_end_m)
    if not hi - lo > X_TOL:
        raise InputError(f"a lap joint needs its components to overlap; '{between[0]}' spans "
                         f"{ca.x_start_m:g}-{ca.x_end_m:g} m, '{between[1]}' {cb.x_start_m:g}-"
                         f"{cb.x_end_m:g} m", field=f"{w}.between")
    x = _num(v, "x_m", w, 0.5 * (lo + hi))
    if not lo - X_TOL <= x <= hi + X_TOL:
        raise InputError(f"the bolt at {x:g} m is outside the overlap {lo:g}-{hi:g} m", field=f"{w}.x_m")
    contact = _num(v, "contact_length_m", w, hi - lo, positive=True)
    a = at({"component": between[0], "x_m": x}, w)
    b = at({"component": between[1], "x_m": x}, w)
    params = {}
    extra = _table(v, "params", w, required=False)
    for k in extra:
        params[k] = _num(extra, k, f"{w}.params")
    law = JointLaw(_str(v, "model", w, "linear_stiffness"), params, field=w)
    return {"name": nm, "a": a, "b": b, "law": law, "radius_m": 0.5 * contact, "stations": _stations(v, w),
            "transverse_stiffness": _num(v, "transverse_stiffness_n_per_m", w, positive=True),
            "layer": None, "geometry": "lap", "contact_length_m": contact}


def _connected(comps: Mapping[str, Component], joints: list[dict]) -> None:
    names = list(comps)
    seen = {names[0]}
    grow = True
    while grow:
        grow = False
        for j in joints:
            ends = {j["a"][0], j["b"][0]}
            if ends & seen and not ends <= seen:
                seen |= ends
                grow = True
    loose = [n for n in names if n not in seen]
    if loose:
        raise InputError(f"component(s) {', '.join(loose)} are not connected to "
                         f"'{names[0]}' by any joint", field=f"components.{loose[0]}")


def _damping(t: Mapping[str, Any]) -> Damping:
    kind = _str(t, "type", "damping", "none")
    if kind == "rayleigh":
        return Damping("rayleigh", alpha=_num(t, "alpha", "damping", 0.0), beta=_num(t, "beta", "damping", 0.0))
    if kind == "modal":
        r = t.get("ratios")
        if not (isinstance(r, list) and r and all(isinstance(x, (int, float)) and 0 <= x < 1 for x in r)):
            raise InputError("must be a non-empty list of ratios in [0, 1)", field="damping.ratios")
        return Damping("modal", ratios=tuple(float(x) for x in r))
    if kind != "none":
        raise InputError(f"must be none, rayleigh or modal, got '{kind}'", field="damping.type")
    return Damping()


def load_structure(path: str | Path) -> Structure:
    """The structure described by the TOML file ``path``; errors name the file and key."""
    d = read_toml(path, what="structure file")
    try:
        return structure_from_dict(d)
    except InputError as exc:
        if exc.file is None:
            raise InputError(exc.message, file=str(path), field=exc.field) from None
        raise
