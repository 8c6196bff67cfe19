"""Where a model fails on records under any excitation: maps, curves, findings, evidence.

Maps (NRMSE units, as for sines: squares of a partition's cells add up to the pooled
NRMSE^2):

- by run: each record's NRMSE and noise floor, with its excitation and rms displacement;
- by band: the residual's power in frequency bands (an octave wide, from the
  records' lowest resolved frequency to Nyquist; Parseval over the judged span);
- by line (periodic excitation): the residual's periodic part (mean over the judged
  periods, per DFT line of the period) on the excited lines, on the lines not excited
  (where a nonlinearity the model misses puts its distortion) and the constant; the
  aperiodic rest (noise, drift, transients);
- by quadrant of (sign of displacement about the motion's centre, sign of velocity);
- near reversals (speed below ``SLOW`` of the record's 99th-percentile speed) against
  mid-stroke (above ``FAST`` of it), per-sample rms of each;
- over time: the NRMSE of each unit (period or block) of each record.

Curves: per record, the energy dissipated over the judged samples and the least-squares
stiffness, measured and model, against the rms displacement; the log-log slope of the
dissipated energy against rms displacement over the records (at least two levels).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.compare.describe import overall_finding, pct_text, state_findings
from labjoint.compare.evidence import fitted_params
from labjoint.compare.residuals import parseval_weights, state_dict
from labjoint.compare.runs import split_every_nth
from labjoint.errors import InputError
from labjoint.signal.cycles import cycles as resample_cycles

BANDS_PER_OCTAVE = 1
SLOW = 0.1
FAST = 0.5
VALIDATION_FRACTION = 1.0 / 3.0
LOOP_TOL_PCT = 2.0


def _span(r: Any) -> slice:
    return slice(int(r.run.spans[0, 0]), int(r.run.spans[-1, 1]))


def line_parts(e: np.ndarray, bounds: np.ndarray, excited: Sequence[int]) -> dict[str, float]:
    """Sums of squares of ``e`` over the periods ``bounds`` in its constant, excited-line,
    not-excited-line and aperiodic parts (each period resampled at the nearest integer
    number of samples; DFT line k is k / period)."""
    per = float(np.mean(np.diff(bounds)))
    m = max(16, int(round(per)))
    c = resample_cycles(e, bounds, m, check=False)
    C = np.fft.rfft(c, axis=1) / m
    w = parseval_weights(m)
    mean = C.mean(axis=0)
    periodic = c.shape[0] * per * w * np.abs(mean) ** 2
    total = float(np.sum(c * c)) * per / m
    exc = np.zeros(C.shape[1], bool)
    idx = [k for k in excited if 0 < k < C.shape[1]]
    exc[idx] = True
    return {"constant": float(periodic[0]), "excited": float(periodic[exc].sum()),
            "not_excited": float(periodic[1:][~exc[1:]].sum()),
            "aperiodic": max(total - float(periodic.sum()), 0.0)}


def _excited_lines(m: Any) -> list[int]:
    exc, per_s = m.excitation, float(np.mean(np.diff(m.bounds))) / m.fs
    if exc.kind == "sine":
        return [1]
    return sorted({int(round(f * per_s)) for f in exc.lines_hz})


@dataclass
class RecordMaps:
    """The maps of the module docstring (``to_dict`` for JSON)."""

    runs: list[str]
    excitation: list[str]
    displacement_rms_m: np.ndarray
    run_nrmse: np.ndarray
    run_noise: np.ndarray
    band_edges_hz: np.ndarray
    band_nrmse: np.ndarray
    lines: dict[str, float] | None
    quadrant_nrmse: np.ndarray
    quadrant_rms: np.ndarray
    reversal_rms: float
    midstroke_rms: float
    unit_nrmse: dict[str, np.ndarray] = field(default_factory=dict)
    nrmse: float = float("nan")

    def to_dict(self) -> dict[str, Any]:
        return {
            "by_run": {"runs": self.runs, "excitation": self.excitation,
                       "displacement_rms_m": self.displacement_rms_m, "nrmse": self.run_nrmse,
                       "noise_floor": self.run_noise},
            "by_band": {"edges_hz": self.band_edges_hz, "nrmse": self.band_nrmse},
            "by_line": self.lines,
            **state_dict(self.quadrant_nrmse, self.quadrant_rms, self.reversal_rms,
                         self.midstroke_rms),
            "over_time": dict(self.unit_nrmse),
        }


def record_maps(evals: Sequence[Any], noise: dict[str, float]) -> RecordMaps:
    """Residual maps of evaluated records (module docstring)."""
    lo = min(r.run.fs / max(_span(r).stop - _span(r).start, 1) for r in evals)
    hi = max(0.5 * r.run.fs for r in evals)
    n_b = max(1, int(np.ceil(BANDS_PER_OCTAVE * np.log2(hi / lo))))
    edges = lo * (hi / lo) ** (np.arange(n_b + 1) / n_b)
    band = np.zeros(n_b)
    q_e2, q_n, rev, mid = np.zeros(4), np.zeros(4), np.zeros(2), np.zeros(2)
    lines: dict[str, float] | None = {"constant": 0.0, "excited": 0.0, "not_excited": 0.0,
                                      "aperiodic": 0.0}
    ssf = n_all = 0.0
    units: dict[str, np.ndarray] = {}
    for r in evals:
        j = _span(r)
        e, f = r.residual[j], r.run.data.force[j]
        u, v = r.run.data.inputs.u[j], r.run.data.inputs.v[j]
        ssf += float(f @ f)
        n_all += f.size
        E = np.fft.rfft(e)
        p = parseval_weights(e.size) * np.abs(E) ** 2 / e.size
        fr = np.fft.rfftfreq(e.size, 1.0 / r.run.fs)
        band += np.bincount(np.clip(np.searchsorted(edges, fr, side="right") - 1, 0, n_b - 1),
                            p, n_b)
        centre = 0.5 * (u.max() + u.min())
        q = np.where(u >= centre, np.where(v >= 0, 0, 1), np.where(v < 0, 2, 3))
        q_e2 += np.bincount(q, e * e, 4)
        q_n += np.bincount(q, None, 4)
        top = float(np.percentile(np.abs(v), 99))
        slow, fast = np.abs(v) < SLOW * top, np.abs(v) > FAST * top
        rev += [float(e[slow] @ e[slow]), float(slow.sum())]
        mid += [float(e[fast] @ e[fast]), float(fast.sum())]
        if lines is not None and r.run.bounds is not None:
            for k, x in line_parts(r.residual, r.run.bounds, _excited_lines(r.run)).items():
                lines[k] += x
        else:
            lines = None
        with np.errstate(invalid="ignore", divide="ignore"):
            units[r.name] = np.sqrt(r.unit_sse() / r.unit_ssf())
    mean_f2 = ssf / max(n_all, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        quad_rms = np.sqrt(q_e2 / q_n / mean_f2)
    return RecordMaps(
        [r.name for r in evals], [r.run.excitation.kind for r in evals],
        np.array([r.run.axes()["displacement_rms_m"] for r in evals]),
        np.array([r.nrmse for r in evals]), np.array([noise.get(r.name, np.nan) for r in evals]),
        edges, np.sqrt(band / ssf),
        {k: float(np.sqrt(x / ssf)) for k, x in lines.items()} if lines is not None else None,
        np.sqrt(q_e2 / ssf), quad_rms, float(np.sqrt(rev[0] / max(rev[1], 1) / mean_f2)),
        float(np.sqrt(mid[0] / max(mid[1], 1) / mean_f2)), units,
        float(np.sqrt(sum(r.sse for r in evals) / ssf)))


@dataclass
class RecordCurves:
    """Per record: rms displacement, energy dissipated and stiffness, measured and model;
    the dissipation's log-log slope against rms displacement."""

    runs: list[str]
    displacement_rms_m: np.ndarray
    energy_measured: np.ndarray
    energy_model: np.ndarray
    stiffness_measured: np.ndarray
    stiffness_model: np.ndarray
    energy_slope: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        return {"runs": self.runs, "displacement_rms_m": self.displacement_rms_m,
                "energy_loss_measured_j": self.energy_measured,
                "energy_loss_model_j": self.energy_model,
                "stiffness_measured_n_per_m": self.stiffness_measured,
                "stiffness_model_n_per_m": self.stiffness_model,
                "dissipation_vs_amplitude_slope": self.energy_slope}


def record_curves(evals: Sequence[Any]) -> RecordCurves:
    U = np.array([r.run.axes()["displacement_rms_m"] for r in evals])
    Em = np.array([r.energy_measured for r in evals])
    Ed = np.array([r.energy_model for r in evals])
    slope = {}
    for side, E in (("measured", Em), ("model", Ed)):
        ok = (E > 0) & (U > 0)
        slope[side] = (float(np.polyfit(np.log(U[ok]), np.log(E[ok]), 1)[0])
                       if ok.sum() >= 2 and np.ptp(np.log(U[ok])) > 0.05 else float("nan"))
    return RecordCurves([r.name for r in evals], U, Em, Ed,
                        np.array([r.stiffness_measured for r in evals]),
                        np.array([r.stiffness_model for r in evals]), slope)


TRACE_POINTS = 2048


def record_traces(evals: Sequence[Any], n_points: int = TRACE_POINTS) -> dict[str, dict[str, Any]]:
    """Per record: displacement, measured and model force over the judged span, every
    k-th sample (at most ``n_points``), with their times."""
    out = {}
    for r in evals:
        j = _span(r)
        step = max(1, int(np.ceil((j.stop - j.start) / n_points)))
        s = slice(j.start, j.stop, step)
        out[r.name] = {"time_s": np.arange(j.start, j.stop, step) / r.run.fs,
                       "displacement_m": r.run.data.inputs.u[s],
                       "force_measured_n": r.run.data.force[s], "force_model_n": r.model_force[s]}
    return out


def record_failures(ev: Any, maps: RecordMaps, curves: RecordCurves, floor: float,
                    factor: float) -> list[dict[str, Any]]:
    """Where the model fails on the records, in sentences with numbers."""
    out, done = overall_finding(ev.nrmse(), floor, factor)
    if done:
        return out
    for attr, noun in (("energy_loss_error_pct", "dissipation"), ("stiffness_error_pct", "stiffness")):
        err = np.array([getattr(r, attr) for r in ev.runs], dtype=float)
        err = err[np.isfinite(err)]
        if err.size and abs(float(np.mean(err))) >= LOOP_TOL_PCT:
            m = float(np.mean(err))
            word = "under-predicts" if m < 0 else "over-predicts"
            out.append({"where": noun, "text": f"{word} {noun} by {abs(m):.3g} % on average"})
    b = maps.band_nrmse
    if b.size and np.max(b) > floor:
        i = int(np.argmax(b))
        share = float(b[i] ** 2 / max(np.sum(b ** 2), 1e-300))
        if share > 0.3:
            out.append({"where": "by band",
                        "text": (f"{100 * share:.0f} % of the squared error lies in "
                                 f"{maps.band_edges_hz[i]:.3g}-{maps.band_edges_hz[i + 1]:.3g} Hz "
                                 f"({pct_text(b[i])} NRMSE)")})
    if maps.lines is not None:
        L = maps.lines
        total = sum(x * x for x in L.values())
        named = {"not_excited": "lines the excitation does not excite (nonlinear distortion "
                                "the model does not reproduce)",
                 "excited": "the excited lines (the model's response to the drive itself)",
                 "constant": "a constant force", "aperiodic": "an aperiodic part (drift, transient)"}
        for k in sorted(named, key=lambda k: -L[k]):
            if L[k] > floor and L[k] ** 2 > 0.2 * total:
                out.append({"where": "by line", "text": f"{pct_text(L[k])} NRMSE is on {named[k]}"})
    out += state_findings(maps.quadrant_rms, maps.reversal_rms, maps.midstroke_rms, floor,
                          "near reversals (low speed)", "at mid-stroke (high speed)")
    if len(maps.runs) > 1:
        i = int(np.nanargmax(maps.run_nrmse))
        out.append({"where": "by run",
                    "text": (f"worst run: {maps.runs[i]} ({maps.excitation[i]}, rms "
                             f"{maps.displacement_rms_m[i] * 1e6:.3g} µm): NRMSE "
                             f"{pct_text(maps.run_nrmse[i])}")})
    return out


def added_force_character(base: Any, cand: Any) -> str:
    """How the force a candidate adds relates to the motion: least squares of the added
    force on displacement (about its centre), velocity and a constant, as shares of its
    power, on the record where it is largest."""
    best, best_pow = None, -1.0
    for rb, rc in zip(base.runs, cand.runs):
        j = _span(rb)
        d = (rc.model_force - rb.model_force)[j]
        if float(d @ d) > best_pow:
            best, best_pow = (rb, d, j), float(d @ d)
    if best is None or best_pow <= 0:
        return "adds no force on the data"
    rb, d, j = best
    u, v = rb.run.data.inputs.u[j], rb.run.data.inputs.v[j]
    cols = {"stiffness-like (with displacement)": u - u.mean(),
            "loss-like (with velocity)": v - v.mean(), "constant": np.ones_like(u)}
    shares = {}
    for name, x in cols.items():
        c = float(x @ d) / float(x @ x)
        shares[name] = c * c * float(x @ x) / best_pow
    rest = max(0.0, 1.0 - sum(shares.values()))
    main = max(shares, key=lambda k: shares[k])
    parts = ", ".join(f"{k} {100 * s:.0f} %" for k, s in shares.items() if s > 0.05)
    tail = f"; {100 * rest:.0f} % not linear in the motion (hysteretic or nonlinear)" if rest > 0.05 else ""
    return f"added force is mostly {main} ({parts}{tail}) [largest in {rb.name}]"


def removed_part(base_maps: RecordMaps, cand_maps: RecordMaps) -> str:
    """The band (or line class) where the candidate lowers the residual most."""
    if base_maps.lines is not None and cand_maps.lines is not None:
        drops = {k: base_maps.lines[k] ** 2 - cand_maps.lines[k] ** 2 for k in base_maps.lines}
        k = max(drops, key=lambda x: drops[x])
        if drops[k] > 0:
            return (f"reduces the residual on the {k.replace('_', '-')} lines "
                    f"{pct_text(base_maps.lines[k])} -> {pct_text(cand_maps.lines[k])}")
    d = base_maps.band_nrmse ** 2 - cand_maps.band_nrmse ** 2
    if not d.size or d.max() <= 0:
        return "removes no part of the residual"
    i = int(np.argmax(d))
    e = base_maps.band_edges_hz
    return (f"reduces the residual most in {e[i]:.3g}-{e[i + 1]:.3g} Hz "
            f"{pct_text(base_maps.band_nrmse[i])} -> {pct_text(cand_maps.band_nrmse[i])}")


@dataclass(frozen=True)
class RecordKind:
    """Set-level operations of records (:class:`labjoint.compare.measurement.Kind`)."""

    name: str = "record"

    def split(self, ms: Sequence[Any]) -> tuple[list[Any], list[Any], str]:
        """Two or more records: every 3rd by rms displacement is validation (both ends stay
        in the fit). One record: its last third (whole units) is validation, the model still
        run along the whole history."""
        if len(ms) >= 2:
            return split_every_nth(ms, [m.axes()["displacement_rms_m"] for m in ms], 3,
                                   "by rms displacement")
        m = ms[0]
        k = int(m.spans.shape[0])
        n_val = max(1, int(round(VALIDATION_FRACTION * k)))
        if k - n_val < 1 or k < 3:
            raise InputError(f"run '{m.name}' has {k} units; splitting one record into fit and "
                             "validation parts needs at least 3", field="runs")
        return ([m.part(0, k - n_val, "fit")], [m.part(k - n_val, k, "validation")],
                f"validation: the last {n_val} of {k} units of the record (its last third), "
                "the model run along the whole history")

    def maps(self, evals: Sequence[Any], noise: dict[str, float]) -> RecordMaps:
        return record_maps(evals, noise)

    def curves(self, evals: Sequence[Any]) -> RecordCurves:
        return record_curves(evals)

    def loops(self, evals: Sequence[Any]) -> dict[str, dict[str, Any]]:
        return record_traces(evals)

    def failures(self, ev: Any, maps: RecordMaps, curves: RecordCurves, floor: float,
                 factor: float) -> list[dict[str, Any]]:
        return record_failures(ev, maps, curves, floor, factor)

    def evidence(self, effect: str, base: Any, cand: Any, base_maps: RecordMaps,
                 cand_maps: RecordMaps, fit: Any, validation: str) -> str:
        runs = ", ".join(f"{rb.name} {pct_text(rb.nrmse)} -> {pct_text(rc.nrmse)}"
                         for rb, rc in zip(base.runs, cand.runs))
        parts = (added_force_character(base, cand), f"NRMSE by run: {runs}",
                 removed_part(base_maps, cand_maps), validation, fitted_params(fit, effect))
        return "; ".join(p for p in parts if p)
