"""Plain sentences that say where a model's error is, from the residual maps and curves.

Each finding is ``{"where": <topic>, "text": <sentence citing numbers>}``. A finding is
reported only when it stands out: loop errors beyond ``LOOP_TOL_PCT`` and beyond three
standard errors of their scatter over runs (dissipation only where the measured loss
factor is at least ``MIN_LOSS_FACTOR``), trends over frequency or amplitude that change by
more than half the mean error, slopes that differ by more than ``SLOPE_TOL``, residual parts above the noise
floor. When the pooled NRMSE is within the adequacy factor of the noise floor the only
finding says so.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.compare.curves import PhysicsCurves
from labjoint.compare.metrics import Evaluation
from labjoint.compare.residuals import QUADRANTS, ResidualMaps

LOOP_TOL_PCT = 2.0
SLOPE_TOL = 0.2
MIN_LOSS_FACTOR = 0.002


def pct_text(x: float) -> str:
    return f"{100 * x:.2g} %" if abs(x) < 0.1 else f"{100 * x:.3g} %"


def _um(x: float) -> str:
    return f"{x * 1e6:.3g} µm"


def _nanmean(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.mean(x)) if x.size else float("nan")


def _word(x: float) -> str:
    return "under-predicts" if x < 0 else "over-predicts"


def _trend(values: np.ndarray, keys: np.ndarray, noun: str, what: str, unit: str,
           mean: float | None) -> str:
    """A sentence about how the error changes from the lowest to the highest key, or ""."""
    order = np.argsort(keys)
    v, k = values[order], keys[order]
    if v.size < 2 or not np.all(np.isfinite(v)):
        return ""
    a, b = float(v[0]), float(v[-1])
    if abs(b - a) < max(LOOP_TOL_PCT, 0.5 * (abs(mean) if mean is not None else 0.0)):
        return ""
    span = f"({a:+.3g} % at {k[0]:.3g} {unit} -> {b:+.3g} % at {k[-1]:.3g} {unit})"
    if np.sign(a) == np.sign(b) or min(abs(a), abs(b)) < LOOP_TOL_PCT:
        end = "higher" if abs(b) > abs(a) else "lower"
        lead = "" if mean is not None else f"{_word(b if end == 'higher' else a)} {noun}"
        return f"{lead}, more so at {end} {what} {span}" if mean is not None \
            else f"{lead} mainly at {end} {what} {span}"
    return f"{_word(b)} {noun} at higher {what} and {_word(a)} it at lower {what} {span}"


def _groups(curves: PhysicsCurves, err: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, str, str]]:
    """(mean error per group, group key) by frequency class and by amplitude third."""
    out = []
    lev = curves.levels
    if lev.max() >= 1:
        ks = range(int(lev.max()) + 1)
        out.append((np.array([_nanmean(err[lev == k]) for k in ks]),
                    np.array([np.median(curves.frequency_hz[lev == k]) for k in ks]),
                    "frequency", "Hz"))
    U = curves.amplitude_m
    order = np.argsort(U)
    if order.size >= 2:
        thirds = [p for p in np.array_split(order, min(3, order.size)) if p.size]
        out.append((np.array([_nanmean(err[p]) for p in thirds]),
                    np.array([np.median(U[p]) * 1e6 for p in thirds]), "amplitude", "µm"))
    return out


def _loop_finding(ev: Evaluation, curves: PhysicsCurves, attr: str, noun: str, where: str
                  ) -> dict[str, str] | None:
    err = np.array([getattr(r, attr) for r in ev.runs], dtype=float)
    if attr == "energy_loss_error_pct":
        # a relative loss error means little where the measured loop has (almost) no area
        eta = np.array([r.energy_measured / (np.pi * r.run.force_amplitude_n * r.run.amplitude_m)
                        for r in ev.runs])
        err[~(eta >= MIN_LOSS_FACTOR)] = np.nan
        if not np.any(np.isfinite(err)):
            gen = max(ev.runs, key=lambda r: abs(r.energy_model))
            if abs(gen.energy_model) > MIN_LOSS_FACTOR * np.pi * gen.run.force_amplitude_n * gen.run.amplitude_m:
                return {"where": where, "text": (f"the model dissipates {gen.energy_model:.3g} J per "
                                                 f"cycle at {gen.run.frequency_hz:g} Hz where the "
                                                 "measured loop has no area")}
            return None
    ok = np.isfinite(err)
    if ok.sum() == 0:
        return None
    mean = float(np.mean(err[ok]))
    se = float(np.std(err[ok], ddof=1) / np.sqrt(ok.sum())) if ok.sum() > 1 else 0.0
    if abs(mean) >= LOOP_TOL_PCT and abs(mean) >= 3 * se:
        text = f"{_word(mean)} {noun} by {abs(mean):.3g} % on average"
        for v, k, what, unit in _groups(curves, err):
            t = _trend(v, k, noun, what, unit, mean)
            if t:
                return {"where": where, "text": text + t}
        return {"where": where, "text": text}
    for v, k, what, unit in _groups(curves, err):
        t = _trend(v, k, noun, what, unit, None)
        if t:
            return {"where": where, "text": t}
    worst = int(np.nanargmax(np.abs(np.where(ok, err, 0.0))))
    if abs(err[worst]) < 3 * LOOP_TOL_PCT:
        return None
    r = ev.runs[worst]
    return {"where": where, "text": (f"{noun} is right on average but off by {err[worst]:+.3g} % "
                                     f"at {r.run.frequency_hz:g} Hz, {_um(r.run.amplitude_m)}")}


def _lossless_finding(c: PhysicsCurves) -> list[dict[str, str]]:
    """Runs where the model dissipates (almost) nothing and the measurement does not."""
    only = [n for n in c.lossless["model"] if n not in set(c.lossless["measured"])]
    if not only:
        return []
    sel = np.isin(np.array(c.runs), only)
    U = c.amplitude_m[sel]
    return [{"where": "dissipation vs amplitude",
             "text": (f"the model dissipates almost nothing in {len(only)} of {len(c.runs)} runs "
                      f"(amplitudes {_um(float(U.min()))} to {_um(float(U.max()))}), where the "
                      "measurement dissipates: it sticks where the joint already slips or "
                      "loses energy")}]


def _slope_findings(c: PhysicsCurves) -> list[dict[str, str]]:
    out = _lossless_finding(c)
    meas, mod = c.energy_slope["measured"], c.energy_slope["model"]
    diffs = [(f, meas[f], mod[f]) for f in meas if np.isfinite(meas[f]) and np.isfinite(mod[f])]
    if diffs:
        f, a, b = max(diffs, key=lambda x: abs(x[1] - x[2]))
        if abs(a - b) > SLOPE_TOL:
            out.append({"where": "dissipation vs amplitude",
                        "text": (f"measured dissipation grows like amplitude^{a:.2f}, the model's "
                                 f"like amplitude^{b:.2f} (at {f:g} Hz)")})
    a, b = c.frequency_exponent["measured"], c.frequency_exponent["model"]
    if np.isfinite(a) and np.isfinite(b) and abs(a - b) > SLOPE_TOL:
        out.append({"where": "dissipation vs frequency",
                    "text": (f"measured dissipation scales like frequency^{a:.2f} at equal "
                             f"amplitude, the model's like frequency^{b:.2f}")})
    ks, kd = c.stiffness_slope["measured"], c.stiffness_slope["model"]
    diffs = [(f, ks[f], kd[f]) for f in ks if np.isfinite(ks[f]) and np.isfinite(kd[f])]
    if diffs:
        f, a, b = max(diffs, key=lambda x: abs(x[1] - x[2]))
        if abs(a - b) > 0.05:
            out.append({"where": "stiffness vs amplitude",
                        "text": (f"measured stiffness changes by {100 * a:+.3g} % per e-fold of "
                                 f"amplitude, the model's by {100 * b:+.3g} % (at {f:g} Hz)")})
    return out


def state_findings(q: np.ndarray, reversal_rms: float, midstroke_rms: float, floor: float,
                   near: str = "near reversals", mid: str = "at mid-stroke") -> list[dict[str, str]]:
    """Findings over the motion's state: the error concentrating near reversals or at
    mid-stroke (rms ratio beyond 1.5), or in one quadrant of (u, v) (beyond 1.3x the
    quietest), when above the noise floor."""
    out = []
    r = reversal_rms / midstroke_rms if midstroke_rms > 0 else float("inf")
    if reversal_rms > floor and (r > 1.5 or r < 1 / 1.5):
        out.append({"where": "reversals",
                    "text": (f"the error concentrates {near if r > 1 else mid}: rms "
                             f"{pct_text(reversal_rms)} {near} against {pct_text(midstroke_rms)} {mid}")})
    if np.all(np.isfinite(q)) and q.max() > floor and q.max() > 1.3 * q.min():
        i = int(np.argmax(q))
        out.append({"where": "by quadrant",
                    "text": (f"largest while {QUADRANTS[i]}: rms {pct_text(q[i])} against "
                             f"{pct_text(q.min())} in the quietest quadrant")})
    return out


def _map_findings(m: ResidualMaps, floor: float) -> list[dict[str, str]]:
    out = []
    h = m.harmonic
    named = {"constant": "a constant force (harmonic 0, the loop's mean force)",
             "odd": "the odd harmonics (the loop's symmetric shape)",
             "even": "the even harmonics (the loop is asymmetric)",
             "drift": "a drift from cycle to cycle (the loop changes over time)"}
    total = sum(h[k] ** 2 for k in named)
    for k in sorted(named, key=lambda k: -h[k]):
        if h[k] > floor and h[k] ** 2 > 0.2 * total:
            extra = ""
            if k == "odd":
                ph = m.per_harmonic
                top = int(np.argmax(ph[1:])) + 1
                extra = f"; harmonic {top} carries {pct_text(ph[top])}"
            out.append({"where": "by harmonic",
                        "text": f"{pct_text(h[k])} NRMSE is in {named[k]}{extra}"})
    out += state_findings(m.quadrant_rms, m.reversal_rms, m.midstroke_rms, floor)
    grid, noise = m.grid_nrmse, m.grid_noise
    if np.any(np.isfinite(grid)):
        i, j = np.unravel_index(np.nanargmax(grid), grid.shape)
        ratio = grid[i, j] / noise[i, j] if np.isfinite(noise[i, j]) and noise[i, j] > 0 else np.nan
        if grid[i, j] > 1.5 * floor:
            out.append({"where": "by run",
                        "text": (f"worst run: {m.grid_runs[i][j]} at {m.frequencies_hz[i]:g} Hz, "
                                 f"{_um(m.grid_amplitude_m[i, j])} (NRMSE {pct_text(grid[i, j])}"
                                 + (f", {ratio:.2g}x its noise floor)" if np.isfinite(ratio) else ")"))})
    return out


def overall_finding(nr: float, floor: float, factor: float) -> tuple[list[dict[str, str]], bool]:
    """([the overall finding], whether it is the only one: the NRMSE within ``factor`` x
    the noise floor, where nothing else is worth saying)."""
    if np.isfinite(floor) and nr <= factor * floor:
        return [{"where": "overall",
                 "text": (f"NRMSE {pct_text(nr)} is within {factor:g}x the noise floor "
                          f"({pct_text(floor)}): no error beyond measurement noise")}], True
    times = f" ({nr / floor:.3g}x)" if floor > 0 else ""     # noise-free data: a floor of 0
    return [{"where": "overall",
             "text": f"NRMSE {pct_text(nr)} against a noise floor of {pct_text(floor)}{times}"}], False


def failures(ev: Evaluation, maps: ResidualMaps, curves: PhysicsCurves, noise_floor: float,
             factor: float = 1.5) -> list[dict[str, Any]]:
    """The sentences of the module docstring, most telling first."""
    out, done = overall_finding(ev.nrmse(), noise_floor, factor)
    if done:
        return out
    for attr, noun, where in (("energy_loss_error_pct", "dissipation", "dissipation"),
                              ("stiffness_error_pct", "stiffness", "stiffness")):
        f = _loop_finding(ev, curves, attr, noun, where)
        if f:
            out.append(f)
    out += _slope_findings(curves)
    out += _map_findings(maps, noise_floor)
    return out
