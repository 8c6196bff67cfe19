"""Trends over a set of runs: energy loss, damping and stiffness by both methods of seed
002 (hysteresis loop, Eq. 1; stick-slip boundary, Eqs. 6-9) with their standard
uncertainties, against excitation, displacement and force amplitude and bolt torque;
seed 002 Tables 2-4 built from them; and the dissipation exponent of seed 001
(W ~ F^(3 + chi), :mod:`labjoint.identify.powerlaw`).

The one place the CLI (``labjoint analyze --table``), the REST ``GET /trends`` and the
dashboard's trends view get these numbers from. All values SI; display units are the
callers' (:func:`format_trends` for text).

Uncertainties (standard, of the mean over the steady cycles): the loop's W and C as
:mod:`labjoint.identify.resolution` states them (sensor phase and cycle scatter); K, U
and F their cycle scatter / sqrt(n). The stick-slip values are model values fixed by
K_t (in micro-slip W = 2 K_t U^2): their cycle scatter / sqrt(n) and K_t's relative
uncertainty, in quadrature.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Iterable

from labjoint.errors import InputError, LabjointError
from labjoint.identify.methods import MODEL_NOTE, analyze_one, diff_pct
from labjoint.identify.powerlaw import SEGALMAN_RANGE, PowerLawFit, fit_power_law

#: x axes of the trends: key -> (label, SI unit); the first three are amplitudes.
AXES = {"excitation_vpp": ("Excitation amplitude", "Vpp"),
        "displacement_amplitude_m": ("Displacement amplitude", "m"),
        "force_amplitude_n": ("Force amplitude", "N"),
        "torque_nm": ("Bolt torque", "N m")}
#: Amplitude axes: W is a power law of these in micro-slip (log axes, exponent fitted).
AMPLITUDE_AXES = ("excitation_vpp", "displacement_amplitude_m", "force_amplitude_n")
#: Quantities: key -> (label, SI unit); each with a loop and a stick-slip value.
QUANTITIES = {"energy_loss_j": ("Energy loss", "J"),
              "damping_ns_per_m": ("Joint damping", "N s/m"),
              "stiffness_n_per_m": ("Joint stiffness", "N/m")}
#: Row-key prefix of each method's values.
METHOD_PREFIX = {"loop": "", "stickslip": "stickslip_"}
#: The fit every view leads with: loop energy loss against force amplitude (seed 001).
MAIN_FIT = ("loop", "force_amplitude_n")
REFERENCE = (f"seed 001: Segalman's Iwan joint dissipates W ~ F^(3 + chi); micro-slip tests "
             f"give an exponent of {SEGALMAN_RANGE[0]}-{SEGALMAN_RANGE[1]}; a viscous joint 2")
#: Keys of a fit (None when it was refused).
FIT_FIELDS = tuple(PowerLawFit.__dataclass_fields__)
#: Conditions a table is laid out by (seed 002 Table 3: excitation, Table 4: torque).
CONDITIONS = ("excitation_vpp", "torque_nm")
#: Conditions one dissipation exponent must not span: W ~ F^n holds for one joint state
#: (bolt torque) and one excitation frequency; runs at 100 and 400 Hz, or at 2 and 8 N m,
#: are separate series, each fitted on its own (issue 33 item 2).
SERIES = ("frequency_hz", "torque_nm")
#: Frequencies within this relative difference are one (a run's measured frequency).
SAME_FREQUENCY = 0.01


def _sem(summary: dict[str, Any], key: str) -> float:
    n = int(summary.get("cycles") or 0)
    s = summary.get(key + "_std")
    return float(s) / math.sqrt(n) if n > 1 and s is not None else float("nan")


def trend_row(run: Any, friction: Any = None, **settings: Any) -> dict[str, Any]:
    """One run's row: ``analyze_one``'s (both methods when ``friction`` is known, else
    the loop only) with every plotted value's standard uncertainty as ``<key>_uncertainty``."""
    row, results = analyze_one(run, "both" if friction is not None else "loop",
                               friction=friction, **settings)
    loop = results["loop"].summary
    for key in ("displacement_amplitude_m", "force_amplitude_n", "stiffness_n_per_m"):
        row[key] = loop[key]
        row[key + "_uncertainty"] = _sem(loop, key)
    ss = results.get("stickslip")
    if ss is not None:
        kt = ss.shear_stiffness
        rel = abs(float(kt.uncertainty) / kt.value) if kt.value else float("nan")
        for key in QUANTITIES:
            v = ss.summary[key]
            row[f"stickslip_{key}_uncertainty"] = math.hypot(_sem(ss.summary, key), v * rel)
        row["stiffness_diff_pct"] = diff_pct(row["stiffness_n_per_m"], row["stickslip_stiffness_n_per_m"])
    return row


def trend_rows(items: Iterable[Any], friction: Any = None, *, errors: list | None = None,
               force: str = "joint", **settings: Any) -> list[dict[str, Any]]:
    """:func:`trend_row` of each run (a Run, or a run file or CSV path read with the
    ``force`` sensor, "joint" or "reference").

    With ``errors`` a list, a run that cannot be analysed is noted there as
    {"run", "error"} and the others go on; without it the error is raised."""
    from labjoint.storage import read_any
    rows = []
    for item in items:
        name = str(item) if isinstance(item, (str, Path)) else getattr(item, "name", "?")
        try:
            if isinstance(item, (str, Path)):
                run = read_any(item, force=force)
            elif force != "joint":
                raise InputError("an imported CSV record has one force column; the reference "
                                 "force applies to run files only", field="force")
            else:
                run = item
            rows.append(trend_row(run, friction, **settings))
        except LabjointError as exc:
            if errors is None:
                raise
            errors.append({"run": name, "error": str(exc)})
    return rows


def _usable(row: dict[str, Any], method: str) -> bool:
    """Whether a row's W by ``method`` is a measurement (loop W under its resolution is not)."""
    w = row.get(METHOD_PREFIX[method] + "energy_loss_j")
    return w is not None and math.isfinite(w) and w > 0 and not (
        method == "loop" and row.get("below_resolution"))


def exponent_fit(rows: list[dict[str, Any]], method: str = "loop",
                 against: str = "force_amplitude_n") -> dict[str, Any]:
    """W by ``method`` against ``against`` as a power law: the fit, or its refusal in
    ``error`` (fewer than 3 distinct amplitudes, no usable W)."""
    p = METHOD_PREFIX[method]
    out: dict[str, Any] = {"method": method, "quantity": "energy_loss_j", "against": against,
                           **dict.fromkeys(FIT_FIELDS)}
    used = [r for r in rows if _usable(r, method) and isinstance(r.get(against), (int, float))
            and r[against] > 0]
    ids = {id(r) for r in used}
    out["excluded"] = [r["run"] for r in rows if id(r) not in ids]
    out["runs"] = [r["run"] for r in used]
    mixed = mixed_series(used)
    if mixed:
        out["error"] = (f"no single exponent: the runs span {mixed}; W ~ F^n holds for one "
                        "frequency and one bolt torque: see each series' own fit (or filter "
                        "the runs to one)")
        return out
    try:
        fit = fit_power_law([r[against] for r in used], [r[p + "energy_loss_j"] for r in used],
                            [r.get(p + "energy_loss_j_uncertainty") for r in used],
                            x_name=against, y_name=p + "energy_loss_j")
    except LabjointError as exc:
        out["error"] = getattr(exc, "message", str(exc))
        if against == MAIN_FIT[1] and method == MAIN_FIT[0]:
            out["error"] = f"no dissipation exponent: {against} {out['error']}"
        return out
    out.update(fit.to_dict())
    out["error"] = None
    return out


def series_key(row: dict[str, Any]) -> tuple[Any, Any]:
    """(frequency Hz rounded to 3 significant digits, torque N m) of a row: its series."""
    f = row.get("frequency_hz")
    f = float(f"{f:.3g}") if isinstance(f, (int, float)) and math.isfinite(f) else None
    return f, row.get("torque_nm")


def _distinct(values: list[Any], rel: float = 0.0) -> list[Any]:
    out: list[Any] = []
    for v in sorted(v for v in values if v is not None):
        if not out or abs(v - out[-1]) > rel * abs(out[-1]):
            out.append(v)
    return out


def mixed_series(rows: list[dict[str, Any]]) -> str:
    """'' when the rows share one frequency and one torque, else which differ, in words
    ("2 frequencies (100, 400 Hz)")."""
    parts = []
    freqs = _distinct([r.get("frequency_hz") for r in rows], SAME_FREQUENCY)
    if len(freqs) > 1:
        parts.append(f"{len(freqs)} frequencies ({', '.join(f'{f:.4g}' for f in freqs)} Hz)")
    torques = _distinct([r.get("torque_nm") for r in rows])
    if len(torques) > 1:
        parts.append(f"{len(torques)} bolt torques ({', '.join(f'{t:.4g}' for t in torques)} N m)")
    return " and ".join(parts)


def series_fits(rows: list[dict[str, Any]], method: str = "loop",
                against: str = "force_amplitude_n") -> list[dict[str, Any]]:
    """The exponent fit of each series (one frequency, one torque) when the rows hold
    more than one; each fit with its ``frequency_hz`` and ``torque_nm``."""
    groups: dict[tuple[Any, Any], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(series_key(r), []).append(r)
    if len(groups) < 2:
        return []
    out = []
    for (f, t), members in sorted(groups.items(), key=lambda kv: (kv[0][0] or 0, kv[0][1] or 0)):
        fit = exponent_fit(members, method, against)
        out.append({**fit, "frequency_hz": f, "torque_nm": t})
    return out


def varying(rows: list[dict[str, Any]]) -> list[str]:
    """The conditions (excitation, torque) that differ between the rows."""
    return [k for k in CONDITIONS
            if len({r.get(k) for r in rows if r.get(k) is not None}) > 1]


def table_layout(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Seed 002 Tables 2-4 (SI): per run, sorted by the conditions that vary, a row per
    property with the stick-slip model value, the loop value, their uncertainties and
    the difference (loop - model) / loop in %."""
    cond = varying(rows) or []
    ordered = sorted(rows, key=lambda r: tuple((r.get(k) is None, r.get(k) or 0)
                                              for k in cond) + (r["run"],))
    out = []
    for r in ordered:
        for key, (label, unit) in QUANTITIES.items():
            ss = r.get("stickslip_" + key)
            loop = r.get(key)
            below = bool(r.get("below_resolution")) and key != "stiffness_n_per_m"
            out.append({"run": r["run"], "condition": {k: r.get(k) for k in cond},
                        "property": key, "label": label, "unit": unit,
                        "stickslip": ss, "stickslip_uncertainty": r.get(f"stickslip_{key}_uncertainty"),
                        "loop": loop, "loop_uncertainty": r.get(f"{key}_uncertainty"),
                        "below_resolution": below,
                        "diff_pct": None if below or ss is None or loop is None
                        else diff_pct(loop, ss)})
    return {"conditions": cond, "rows": out, "note": MODEL_NOTE}


def build_trends(rows: list[dict[str, Any]], errors: list[dict[str, str]] | None = None
                 ) -> dict[str, Any]:
    """Everything a trends view shows: the rows, the Tables 2-4 layout, the main
    dissipation-exponent fit (loop W against force amplitude) and every method x
    amplitude fit, and the runs that could not be analysed."""
    methods = ["loop"] + (["stickslip"] if any("stickslip_energy_loss_j" in r for r in rows) else [])
    fits = [exponent_fit(rows, m, a) for m in methods for a in AMPLITUDE_AXES]
    main = next(f for f in fits if (f["method"], f["against"]) == MAIN_FIT)
    notes = [] if "stickslip" in methods else [
        "stick-slip columns need the friction coefficient: run a friction test "
        "(labjoint friction RUN) or give it"]
    return {"runs": rows, "errors": list(errors or []), "methods": methods,
            "varying": varying(rows), "axes": {k: {"label": v[0], "unit": v[1],
                                                   "power_law": k in AMPLITUDE_AXES}
                                               for k, v in AXES.items()},
            "table": table_layout(rows), "fit": {**main, "reference": REFERENCE},
            "fits": fits, "series_fits": series_fits(rows, *MAIN_FIT), "notes": notes}


#: Display units of the text table: SI unit -> (shown unit, factor).
DISPLAY = {"J": ("mJ", 1e3), "N s/m": ("Ns/m", 1.0), "N/m": ("MN/m", 1e-6), "m": ("um", 1e6)}


def _num(v: Any, k: float = 1.0) -> str:
    return "-" if v is None or not math.isfinite(float(v)) else f"{float(v) * k:.4g}"


def _pct(v: Any) -> str:
    return "-" if v is None or not math.isfinite(float(v)) else f"{round(float(v), 1) + 0.0:.1f}"


def describe_fit(fit: dict[str, Any]) -> str:
    """One line saying the fitted exponent and its 95 % interval, or why there is none."""
    if fit.get("error"):
        return fit["error"]
    lo, hi = fit["exponent_ci95"]
    label = AXES[fit["against"]][0].lower()
    return (f"dissipation exponent ({fit['method']} W against {label}): "
            f"n = {fit['exponent']:.3g}, 95 % CI [{lo:.3g}, {hi:.3g}], from {fit['n_points']} "
            f"runs at {fit['n_amplitudes']} amplitudes ("
            f"{'weighted' if fit['weighted'] else 'unweighted'} least squares on log W vs log x)")


def format_trends(body: dict[str, Any]) -> str:
    """:func:`build_trends` as plain text: seed 002 Tables 2-4 in display units (mJ,
    Ns/m, MN/m), then the dissipation exponent, the reference range and the notes."""
    table = body["table"]
    cond = table["conditions"]
    heads = ([AXES[k][0].split()[0] + f" ({AXES[k][1]})" for k in cond] or ["Run"]) + [
        "Joint property", "Stick-slip model", "+-", "Hysteresis loop", "+-", "Diff. (%)"]
    lines: list[list[str]] = []
    last = None
    for r in table["rows"]:
        unit, k = DISPLAY.get(r["unit"], (r["unit"], 1.0))
        first = [_num(r["condition"][c]) for c in cond] if cond else [r["run"]]
        if r["run"] == last:
            first = [""] * len(first)
        last = r["run"]
        loop = "below res." if r["below_resolution"] else _num(r["loop"], k)
        lines.append(first + [f"{r['label']} ({unit})", _num(r["stickslip"], k),
                              _num(r["stickslip_uncertainty"], k), loop,
                              _num(r["loop_uncertainty"], k), _pct(r["diff_pct"])])
    widths = [max(len(h), *(len(x[i]) for x in lines)) if lines else len(h)
              for i, h in enumerate(heads)]
    text = ["  ".join(h.rjust(w) for h, w in zip(heads, widths)),
            "  ".join("-" * w for w in widths)]
    text += ["  ".join(c.rjust(w) for c, w in zip(x, widths)) for x in lines]
    text += ["", describe_fit(body["fit"])]
    text += [f"  at {_num(f['frequency_hz'])} Hz, {_num(f['torque_nm'])} N m: {describe_fit(f)}"
             for f in body.get("series_fits", [])]
    text.append(body["fit"]["reference"])
    if "stickslip" in body["methods"]:
        text.append(table["note"])
    text += body["notes"]
    return "\n".join(text)
