"""Both identification methods on runs, side by side (seed 002 Tables 2-4).

For each run: the hysteresis loop (:mod:`labjoint.identify.analyze`, Eq. 1) and the
stick-slip boundary (:mod:`labjoint.identify.stickslip`, Eqs. 2-9) with the
difference in % as the paper gives it, (loop - stick-slip) / loop x 100. K_t comes
from the same run's loop slope (K = 2 K_t, the loop's least-squares slope, with its
uncertainty over the steady cycles); the friction coefficient from a friction test
(:func:`labjoint.identify.friction.identify_friction`), passed in or read from
``<data_dir>/identified.json``.

This is the layer ``labjoint analyze --method loop|stickslip|both`` calls:
:func:`analyze_runs` returns one JSON-ready row per run, :func:`format_table` a table.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.analyze import analyze_run
from labjoint.identify.identified import Identified, load_identified
from labjoint.identify.loop import LoopResult
from labjoint.identify.stickslip import BASIS as STICKSLIP_BASIS
from labjoint.identify.stickslip import StickSlipIdentifier

METHODS = ("loop", "stickslip", "both")
LOOP_BASIS = ("measured: the area and slope of the recorded force-displacement loop "
              "(seed 002 Eq. 1)")
#: Printed under every table with stick-slip columns.
MODEL_NOTE = ("stick-slip columns (model) are seed 002 Eqs. 6-9 evaluated with K_t = K_loop / 2, "
              "mu and the contact law: in micro-slip W = 2 K_t U^2 and C = K / (pi omega) "
              "exactly, so they follow from the loop's stiffness, U and omega; their "
              "difference from the loop columns (measured) is not an independent check.")
STORE_GROUPS = {"loop": "loop", "stickslip": "stickslip"}
#: loop summary keys of design.md's `labjoint analyze --json` row
LOOP_FIELDS = ("frequency_hz", "displacement_amplitude_m", "force_amplitude_n",
               "energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m", "cycles")


def diff_pct(loop: float, stickslip: float) -> float:
    """seed 002 Tables 2-4: (loop - stick-slip) / loop, in %.

    >>> round(diff_pct(1867, 1542), 1)                 # Table 2, damping
    17.4
    """
    return float((loop - stickslip) / loop * 100.0) if loop else float("nan")


def _loop_stiffness_identified(summary: dict[str, Any], run: str, stiffness: str) -> Identified:
    key = "stiffness_n_per_m" if stiffness == "lsq" else "stiffness_secant_n_per_m"
    k, s, n = summary[key], summary[key + "_std"], int(summary["cycles"])
    sem = s / np.sqrt(n) if n > 1 else float("nan")
    return Identified("shear_stiffness", k / 2, sem / 2, "N/m", run,
                      f"loop slope ({stiffness}) / 2, seed 002 Eq. 9", n,
                      {"loop_stiffness_n_per_m": k})


def analyze_one(run: Any, method: str = "both", *, friction: Identified | float | None = None,
                stiffness: str = "lsq", **stickslip_settings: Any) -> tuple[dict[str, Any], dict]:
    """One run by ``method``; returns (row, results) with results["loop"|"stickslip"]."""
    if method not in METHODS:
        raise InputError(f"method must be one of {METHODS}, got {method!r}", field="method")
    md = run.metadata
    row: dict[str, Any] = {"run": run.name, "method": method}
    for key in ("excitation_vpp", "torque_nm", "normal_force_n"):
        if md.get(key) is not None:
            row[key] = md[key]
    results: dict[str, Any] = {}
    loop = None
    if method in ("loop", "both") or stickslip_settings.get("shear_stiffness") is None:
        loop = analyze_run(run)
        results["loop"] = loop
        if method in ("loop", "both"):
            row["loop_basis"] = LOOP_BASIS
            row.update({k: loop.summary[k] for k in LOOP_FIELDS})
            row["energy_loss_j_std"] = loop.summary["energy_loss_j_std"]
            row["damping_ns_per_m_std"] = loop.summary["damping_ns_per_m_std"]
            for key in ("energy_loss_j_uncertainty", "damping_ns_per_m_uncertainty",
                        "energy_loss_j_resolution", "below_resolution"):
                row[key] = loop.summary[key]
    if method in ("stickslip", "both"):
        if friction is None:
            raise InputError("the stick-slip method needs the friction coefficient: identify "
                             "it from a friction-test run (`labjoint friction RUN`, or "
                             "`--friction-run RUN` for one analysis; identify_friction in "
                             "Python) or give it (`--friction MU`)", field="friction")
        settings = dict(stickslip_settings)
        if settings.get("shear_stiffness") is None and loop is not None:
            settings["loop_slope"] = _loop_stiffness_identified(loop.summary, run.name,
                                                                     stiffness)
        est = StickSlipIdentifier(friction, stiffness_method=stiffness, **settings).fit(run)
        ss = est.result_
        results["stickslip"] = ss
        s = ss.summary
        row.setdefault("frequency_hz", s["frequency_hz"])
        row.update({
            "stickslip_energy_loss_j": s["energy_loss_j"],
            "stickslip_damping_ns_per_m": s["damping_ns_per_m"],
            "stickslip_stiffness_n_per_m": s["stiffness_n_per_m"],
            "stickslip_displacement_amplitude_m": s["displacement_amplitude_m"],
            "stickslip_min_boundary_radius_m": s["min_boundary_radius_m"],
            "stickslip_macro_slip_fraction": s["macro_slip_fraction"],
            "stickslip_cycles": s["cycles"],
            "friction_coefficient": ss.friction.value,
            "friction_coefficient_uncertainty": ss.friction.uncertainty,
            "friction_source": ss.friction.source,
            "shear_stiffness_n_per_m": ss.shear_stiffness.value,
            "shear_stiffness_uncertainty_n_per_m": ss.shear_stiffness.uncertainty,
            "shear_stiffness_source": ss.shear_stiffness.source,
            "shear_stiffness_method": ss.shear_stiffness.method,
            "stickslip_basis": STICKSLIP_BASIS,
        })
        if method == "both":
            row["energy_loss_diff_pct"] = diff_pct(row["energy_loss_j"], s["energy_loss_j"])
            row["damping_diff_pct"] = diff_pct(row["damping_ns_per_m"], s["damping_ns_per_m"])
    return row, results


def analyze_runs(runs: Iterable[Any], method: str = "both", *,
                 friction: Identified | float | None = None, data_dir: str | Path | None = None,
                 store: bool = False, stiffness: str = "lsq", force: str = "joint",
                 **stickslip_settings: Any) -> list[dict[str, Any]]:
    """Rows for ``labjoint analyze --method``; ``runs`` are paths or Run objects.

    The friction coefficient: ``friction`` if given, else the latest in
    ``<data_dir>/identified.json``. ``force`` picks the force sensor of run files
    ("joint" or "reference"). ``store`` writes ``processed/loop`` (methods loop and
    both) and ``processed/stickslip`` (stickslip and both) into each run file.
    """
    from labjoint.storage import read_run, write_processed
    if method in ("stickslip", "both") and friction is None and data_dir is not None:
        friction = load_identified(data_dir, "friction_coefficient")
    rows = []
    for item in runs:
        if isinstance(item, (str, Path)):
            run = read_run(item, force=force)
        elif force != "joint":
            raise InputError("an imported CSV record has one force column; --force reference "
                             "applies to run files only", file=str(getattr(item, "path", "")),
                             field="force")
        else:
            run = item
        row, results = analyze_one(run, method, friction=friction, stiffness=stiffness,
                                   **stickslip_settings)
        row["force_sensor"] = force
        rows.append(row)
        if store and run.path:
            if method in ("loop", "both") and "loop" in results:
                write_processed(run.path, STORE_GROUPS["loop"], *loop_processed(results["loop"]))
            if "stickslip" in results:
                arrays, attrs, units = results["stickslip"].processed()
                write_processed(run.path, STORE_GROUPS["stickslip"], arrays, attrs, units)
    return rows


def loop_processed(res: LoopResult) -> tuple[dict[str, Any], dict[str, Any], dict[str, str]]:
    """(arrays, attrs, units) of a loop result for ``processed/loop``."""
    arrays = {"energy_loss": res.energy_loss, "damping": res.damping,
              "stiffness_lsq": res.stiffness_lsq, "stiffness_secant": res.stiffness_secant,
              "displacement_amplitude": res.displacement_amplitude,
              "force_amplitude": res.force_amplitude, "steady": res.steady.astype("i1"),
              "energy_loss_uncertainty": res.energy_loss_uncertainty,
              "below_resolution": res.below_resolution.astype("i1")}
    attrs = {k: v for k, v in res.summary.items() if isinstance(v, (int, float))}
    attrs["basis"] = LOOP_BASIS
    units = {"energy_loss": "J", "damping": "N s/m", "stiffness_lsq": "N/m",
             "stiffness_secant": "N/m", "displacement_amplitude": "m", "force_amplitude": "N",
             "steady": "1", "energy_loss_uncertainty": "J", "below_resolution": "1"}
    return arrays, attrs, units


def format_table(rows: list[dict[str, Any]]) -> str:
    """A plain text table in display units (mJ, Ns/m, MN/m, um), as seed 002 Tables 2-4."""
    cols = [("run", "run", None), ("Vpp", "excitation_vpp", 1.0), ("torque Nm", "torque_nm", 1.0),
            ("U um", "displacement_amplitude_m", 1e6), ("W loop mJ", "energy_loss_j", 1e3),
            ("W model mJ", "stickslip_energy_loss_j", 1e3), ("dW %", "energy_loss_diff_pct", 1.0),
            ("C loop Ns/m", "damping_ns_per_m", 1.0),
            ("C model Ns/m", "stickslip_damping_ns_per_m", 1.0), ("dC %", "damping_diff_pct", 1.0),
            ("K loop MN/m", "stiffness_n_per_m", 1e-6),
            ("K model MN/m", "stickslip_stiffness_n_per_m", 1e-6),
            ("c_min mm", "stickslip_min_boundary_radius_m", 1e3),
            ("mu", "friction_coefficient", 1.0)]
    cols = [c for c in cols if any(r.get(c[1]) is not None for r in rows)]
    if not cols:
        return ""

    def cell(r: dict[str, Any], key: str, scale: float | None) -> str:
        v = r.get(key)
        if v is None:
            return "-"
        if r.get("below_resolution") and key in ("energy_loss_j", "damping_ns_per_m",
                                                 "energy_loss_diff_pct", "damping_diff_pct"):
            return "below res."
        if scale is None:
            return str(v)
        v = float(v) * scale
        return "-" if not np.isfinite(v) else f"{v:.4g}"

    body = [[cell(r, k, s) for _, k, s in cols] for r in rows]
    heads = [h for h, _, _ in cols]
    widths = [max(len(h), *(len(b[i]) for b in body)) for i, h in enumerate(heads)]
    lines = ["  ".join(h.rjust(w) for h, w in zip(heads, widths)),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(c.rjust(w) for c, w in zip(b, widths)) for b in body]
    return "\n".join(lines)
