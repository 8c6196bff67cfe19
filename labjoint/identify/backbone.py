"""Measured backbones from run files: phase resonance, ringdowns and step-sine FRF sets.

Amplitude measure (shared with the model's, :mod:`labjoint.structure.epmc`): the
amplitude of the fundamental of displacement at the response sensor (m); an
acceleration's is divided by w^2 and a velocity's by w (w the run's drive frequency, or
for a ringdown the window's damped frequency).

**Phase resonance** (runs of the ``phase_resonance`` plan, one per level): the force F
and the response R phasors at the drive frequency f (least squares on whole cycles,
8 segments: mean and std of the mean, :func:`labjoint.signal.frf_steps.phasors`). The
residual phase error e = arg(R / F) - target is turned into the frequency of quadrature
at the recorded amplitude X by the force balance on the displacement's in-phase part,
(k(X) - m_eff w^2) X = |F| sin e, so w_r^2 = w^2 + |F| sin e / (m_eff X) (exact for one
mode at a fixed amplitude; :func:`quadrature_at_amplitude`). The loop's own phase slope
S (f_r = f + e / S before) is taken at constant drive, where the amplitude moves along
with f: on the simulated rig's continuous Iwan it put the 1.5 and 5 Vpp levels 0.0003
and 0.0009 Hz (10-12 sd) below the forced harmonic balance of the hidden law at the same
force. f_r's uncertainty holds the record's noise on e and m_eff's on the correction; the
phasors are taken at the generator's frequency, which is known far better than either.
At phase resonance
the force balances the mode's damping alone (single nonlinear mode, Peter and Leine
2017): 2 zeta w^2 m_eff X = |F|, so

    zeta = |F| / (2 m_eff w^2 X),

with m_eff = 1 / (phi_drive phi_sensor) the apparent modal mass between the force and
the sensor: given (``modal_mass_kg``, e.g. from a linear modal test or the model) or
taken from the lowest level, where the mode is linear and the phase slope gives its
damping, zeta_0 = 1 / (S f) (a single mode's phase falls by 1 / zeta rad per unit
relative frequency at resonance). Uncertainties: the phasors' (and e's) scatter,
propagated; m_eff's origin is stated in the notes, and when it comes from the lowest
level's slope, that slope's relative standard error is in every point's damping
uncertainty (it scales them all).

**Ringdowns** (a run recorded with the output off after a dwell): the run's response
channel through :func:`labjoint.signal.ringdown.ringdown_backbone`.

**Per-level broadband FRFs** (an FRF set of broadband records, one per level): method
``frf_levels``, :mod:`labjoint.identify.backbone_levels` (the modes per level, the
amplitude of the mode's response at the sensor).

**Step sine** (a step-sine :class:`~labjoint.signal.frfset.FrfSet`): per sweep,
the phase quadrature between its steps (:func:`frfset_backbone`, the default), or the
steps within ``band`` half-power bandwidths of the peak fitted by one mode,
H(w) = A / (w_r^2 - w^2 + i b w) (displacement per force, Levy's linearised least
squares, each step weighted by its phasor std); zeta = b / (2 w_r); the amplitude is
|H(w_r)| times the sweep's mean force amplitude; uncertainties from the fit's covariance
scaled by its residual.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Iterable

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.backbone_levels import frf_levels_backbone, is_broadband
from labjoint.identify.backbone_mass import mass_from_ringdown
from labjoint.signal.backbone import Backbone, BackbonePoint, is_backbone_file, load_backbones
from labjoint.signal.frf_steps import frfset_from_runs, phasors
from labjoint.signal.frfset import FrfSet
from labjoint.signal.ringdown import ringdown_backbone
from labjoint.storage.reader import open_run

TARGET_DEG = {"displacement": -90.0, "velocity": 0.0, "acceleration": 90.0}
POWER = {"displacement": 0, "velocity": 1, "acceleration": 2}


def _resonance_point(path: Path, segments: int) -> dict:
    with open_run(path) as rf:
        md = rf.metadata
        if md.get("plan") != "phase_resonance" or md.get("ringdown"):
            raise InputError(f"{path}: not a phase_resonance level run (plan {md.get('plan')!r})",
                             file=str(path), field="plan")
        resp, fch = md.get("response_channel"), md.get("force_channel")
        for c in (resp, fch):
            if c not in rf.channel_names:
                raise InputError(f"{path}: no channel {c!r}; channels: {rf.channel_names}",
                                 file=str(path), field="response_channel")
        q = rf.channel(resp).quantity
        if q not in POWER:
            raise InputError(f"{path}: response {resp!r} measures {q}, not a motion", file=str(path),
                             field="response_channel")
        f, fs = float(md["frequency_hz"]), rf.sample_rate_hz
        R, sR = phasors(rf.physical(resp), fs, f, 1, segments)
        F, sF = phasors(rf.physical(fch), fs, f, 1, segments)
        return {"f": f, "R": R[0], "sR": sR[0], "F": F[0], "sF": sF[0], "quantity": q, "sensor": resp,
                "slope": float(md.get("phase_slope_rad_per_hz") or np.nan), "run": path.name,
                "level_vpp": float(md.get("level_vpp", np.nan)),
                "slope_sd": slope_sd(md.get("phase_history"))}


def slope_sd(history) -> float:
    """Standard error (rad/Hz) of the phase slope, the least-squares line of tan(e) against
    f through a level's loop history ([f, e] pairs within 45 deg, as the plan's
    ``level_slope``): s / sqrt(Sxx), s^2 the residuals' sum of squares over n - 2; NaN
    with fewer than 3 pairs (a line through 2 has no residual)."""
    pts = [(float(f), math.tan(float(e))) for f, e in (history or []) if abs(float(e)) < math.pi / 4]
    if len(pts) < 3:
        return float("nan")
    f, t = np.array(pts).T
    sxx = float(np.sum((f - f.mean()) ** 2))
    if sxx <= 0:
        return float("nan")
    b, a = np.polyfit(f, t, 1)
    r = t - (a + b * f)
    return float(math.sqrt(float(r @ r) / (f.size - 2) / sxx))


def phase_resonance_backbone(runs: Iterable[str | Path], *, modal_mass_kg: float | None = None,
                             segments: int = 8, modal_mass_sd_kg: float = 0.0,
                             mass_note: str | None = None) -> Backbone:
    """The backbone of phase-resonance level runs (module docstring); a given
    ``modal_mass_kg`` with its standard uncertainty and a note saying where it came from."""
    pts = sorted((_resonance_point(Path(p), segments) for p in runs), key=lambda d: abs(d["R"]) / d["f"] ** 2)
    if not pts:
        raise InputError("no runs given", field="runs")
    sensors = {p["sensor"] for p in pts}
    if len(sensors) > 1:
        raise InputError(f"runs of different response sensors: {sorted(sensors)}", field="runs")
    rows = []
    for p in pts:
        w = 2 * np.pi * p["f"]
        power = POWER[p["quantity"]]
        e = math.remainder(float(np.angle(p["R"] / p["F"])) - math.radians(TARGET_DEG[p["quantity"]]), 2 * math.pi)
        rel = math.hypot(p["sR"] / abs(p["R"]), p["sF"] / abs(p["F"]))      # relative sd of |R|, |F|; sd of arg
        S = p["slope"] if np.isfinite(p["slope"]) and p["slope"] > 0 else np.nan
        X = abs(p["R"]) / w ** power
        rows.append((p, w, X, e, rel, S))
    notes = ["amplitude: fundamental of displacement at " + pts[0]["sensor"]]
    mass_rel = 0.0                                      # relative sd of m_eff, common to every point
    if modal_mass_kg is None:
        p, w, X, e, _, S = rows[0]
        if not np.isfinite(S):
            raise InputError("the lowest level's run has no phase slope (phase_slope_rad_per_hz): give "
                             "modal_mass_kg", field="modal_mass_kg")
        zeta0 = 1.0 / (S * (p["f"] + e / S))
        modal_mass_kg = abs(p["F"]) / (2 * zeta0 * w * w * X)
        mass_rel = p["slope_sd"] / S if np.isfinite(p["slope_sd"]) else 0.0
        notes.append(f"apparent modal mass {modal_mass_kg:.4g} kg from the lowest level's phase slope "
                     f"(zeta = 1 / (S f) = {zeta0:.4g}" + (f"; the slope's standard error {mass_rel:.2%}, "
                     "in every point's damping uncertainty)" if mass_rel else ")"))
    elif not (math.isfinite(modal_mass_kg) and modal_mass_kg > 0):
        raise InputError(f"must be > 0 kg, got {modal_mass_kg!r}", field="modal_mass_kg")
    else:
        mass_rel = modal_mass_sd_kg / modal_mass_kg
        notes.append(mass_note or f"apparent modal mass {modal_mass_kg:g} kg (given)")
    notes.append("frequency: quadrature at the recorded amplitude by the force balance, "
                 "w_r^2 = w^2 + |F| sin(e) / (m_eff X)")
    out = []
    for p, w, X, e, rel, S in rows:
        fr, fr_sd, zeta = quadrature_at_amplitude(w, abs(p["F"]), X, e, modal_mass_kg, rel, mass_rel)
        out.append(BackbonePoint(X, fr, zeta, "phase_resonance", X * p["sR"] / abs(p["R"]), fr_sd,
                                 zeta * math.hypot(rel, mass_rel),
                                 extra={"run": p["run"], "level_vpp": p["level_vpp"],
                                        "modal_mass_kg": float(modal_mass_kg),
                                        "force_n": abs(p["F"]), "drive_frequency_hz": p["f"],
                                        "phase_error_rad": e}))
    return Backbone(out, "m", "displacement", pts[0]["sensor"], tuple(notes))


def quadrature_at_amplitude(w: float, F: float, X: float, e: float, m: float, rel: float,
                            mass_rel: float) -> tuple[float, float, float]:
    """(f_r Hz, its sd, zeta) of a level recorded at w (rad/s) with force amplitude F,
    displacement amplitude X and quadrature error e (rad): the force balance at that
    amplitude (module docstring), w_r^2 = w^2 + F sin(e) / (m X) and
    zeta = F cos(e) / (2 m w w_r X); f_r's sd from e's (``rel`` rad) and m's relative sd
    ``mass_rel`` on the correction."""
    corr = F * math.sin(e) / (m * X)
    wr2 = w * w + corr
    if wr2 <= 0:
        raise InputError(f"a phase-resonance level {math.degrees(e):.3g} deg off quadrature: the loop did "
                         "not lock near the resonance", field="phase_error")
    wr = math.sqrt(wr2)
    d_wr2 = math.hypot(F * math.cos(e) * rel / (m * X), corr * mass_rel)
    return wr / (2 * np.pi), d_wr2 / (2 * wr) / (2 * np.pi), F * math.cos(e) / (2 * m * w * wr * X)


def ringdown_run_backbone(path: str | Path, channel: str | None = None, *, mode_hz: float | None = None,
                          to_displacement: bool = True, force_channel: str | None = None,
                          modal_mass_kg: float | None = None, **options) -> Backbone:
    """The backbone of one free-decay run's ``channel`` (default: the metadata's
    ``response_channel``); with ``force_channel`` and ``modal_mass_kg`` the exciter's
    force is removed (:func:`labjoint.signal.ringdown.remove_force`)."""
    path = Path(path)
    with open_run(path) as rf:
        channel = channel or rf.metadata.get("response_channel")
        if channel is None:
            raise InputError("name the response channel of the ringdown", file=str(path), field="channel")
        spec = rf.channel(channel)
        x, fs = rf.physical(channel), rf.sample_rate_hz
        force = None if force_channel is None else rf.physical(force_channel)
    try:
        return ringdown_backbone(x, fs, mode_hz=mode_hz, quantity=spec.quantity, units=spec.unit,
                                 sensor=channel, to_displacement=to_displacement, force=force,
                                 modal_mass_kg=modal_mass_kg, **options)
    except InputError as exc:
        raise InputError(exc.message, file=str(path), field=exc.field) from None


def frfset_backbone(s: FrfSet, sensor: str | None = None, band: float = 2.0,
                    method: str = "quadrature", modal_mass_kg: float | None = None) -> Backbone:
    """Frequency, damping and amplitude at resonance per sweep of ``s`` (module docstring).

    ``method``: "quadrature" (default): per sweep the steps where the displacement's phase
    crosses -90 deg from the force's are interpolated (linearly in tan e, e the phase
    error, as the phase-resonance loop does): that is the point of the backbone the sweep's
    force reaches, the same as phase resonance at that force; the damping from the force
    balance there with the apparent modal mass (``modal_mass_kg`` or from the lowest
    sweep, where tan e's slope gives zeta = 1 / (S f)); "fit": the one-mode fit of each
    sweep (an equivalent linear mode over the sweep's amplitudes, which for a nonlinear
    joint lies between the backbone's values at the sweep's smaller amplitudes)."""
    if sensor is not None and sensor not in s.sensors:
        raise InputError(f"no sensor {sensor!r}; sensors: {list(s.sensors)}", field="sensor")
    if method not in ("quadrature", "fit"):
        raise InputError(f"method is 'quadrature' or 'fit', got {method!r}", field="method")
    j = s.sensors.index(sensor) if sensor else int(np.argmax(np.abs(s.response[:, :, 0]).max(axis=0)))
    power = POWER[s.quantity]
    sweeps = []
    for (level, direction), idx in s.groups():
        f = s.frequencies_hz[idx]
        w = 2 * np.pi * f
        sign = {0: 1.0, 1: 1j, 2: -1.0}[power]
        X = s.response[idx, j, 0] / (sign * w ** power)                      # displacement phasors
        sd = s.response_std[idx, j, 0] / (w ** power)
        sweeps.append((level, direction, f, X, sd, s.force[idx]))
    if method == "fit":
        pts = [_sdof_fit(f, X / F, sd / np.abs(F), band, float(np.mean(np.abs(F))), lv, d)
               for lv, d, f, X, sd, F in sweeps]
        note = (f"one-mode fit within {band:g} half-power bandwidths of each sweep's peak; amplitude "
                "= |H(w_r)| x the sweep's mean force")
        return Backbone(pts, "m", "displacement", s.sensors[j], (note,))
    rows = [_quadrature(*sw) for sw in sweeps]
    notes = ["phase quadrature of each sweep (displacement -90 deg from the force), interpolated "
             "in tan(e) between the steps around it"]
    if modal_mass_kg is None:
        lo = min(rows, key=lambda r: r["X"])
        zeta0 = 1.0 / (lo["S"] * lo["f"])
        modal_mass_kg = lo["F"] / (2 * zeta0 * (2 * np.pi * lo["f"]) ** 2 * lo["X"])
        notes.append(f"apparent modal mass {modal_mass_kg:.4g} kg from the lowest sweep's phase slope "
                     f"(zeta = 1 / (S f) = {zeta0:.4g})")
    pts = []
    for r in rows:
        w = 2 * np.pi * r["f"]
        zeta = r["F"] / (2 * modal_mass_kg * w * w * r["X"])
        pts.append(BackbonePoint(r["X"], r["f"], zeta, "step_sine", r["X"] * r["rel"], r["rel"] / r["S"],
                                 zeta * r["rel"], extra={"level_n": r["level"], "direction": r["direction"],
                                                         "modal_mass_kg": float(modal_mass_kg)}))
    return Backbone(pts, "m", "displacement", s.sensors[j], tuple(notes))


def _quadrature(level, direction, f, X, sd, F) -> dict:
    """Where a sweep's phase error e = arg(X / F) + 90 deg crosses zero (module docstring)."""
    e = np.angle(X / F * 1j)                                # displacement -90 deg: e = 0
    order = np.argsort(f)
    f, e, X, sd, F = f[order], e[order], X[order], sd[order], F[order]
    ok = np.abs(e) < np.pi / 4
    cross = np.flatnonzero(ok[:-1] & ok[1:] & (np.sign(e[:-1]) != np.sign(e[1:])) & (e[:-1] > 0))
    if cross.size == 0:
        raise InputError(f"the sweep at {level:g} N ({direction}) does not cross phase resonance "
                         f"({f.min():.4g}-{f.max():.4g} Hz): step through the mode's resonance",
                         field="frfset")
    k = int(cross[0])
    near = np.flatnonzero(ok & (np.abs(np.arange(f.size) - k - 0.5) <= 2.5))    # up to 3 steps each side
    t = np.tan(e[near])
    slope, icpt = np.polyfit(f[near], t, 1)
    fr = -icpt / slope
    a = (fr - f[k]) / (f[k + 1] - f[k])
    Xr = (1 - a) * abs(X[k]) + a * abs(X[k + 1])
    Fr = (1 - a) * abs(F[k]) + a * abs(F[k + 1])
    rel = float(np.max(sd[near] / np.abs(X[near])))         # a phasor's relative sd ~ its phase sd (rad)
    return {"level": float(level), "direction": str(direction), "f": float(fr), "X": float(Xr),
            "F": float(Fr), "S": float(-slope), "rel": max(rel, 1e-12)}


def _sdof_fit(f, H, sd, band, force, level, direction) -> BackbonePoint:
    k = int(np.argmax(np.abs(H)))
    sel = np.ones(f.size, bool)
    for _ in range(2):                                   # fit, then refit on the mode's own band
        w = 2 * np.pi * f[sel]
        h = H[sel]
        wt = 1.0 / np.maximum(np.abs(w * w) * sd[sel], 1e-300) if np.any(sd[sel] > 0) else np.ones(w.size)
        # h (a - w^2 + i b w) = A  ->  [h, i w h, -1] . (a, b, A) = w^2 h   (A complex: 4 real unknowns)
        M = np.column_stack([h, 1j * w * h, -np.ones(w.size), -1j * np.ones(w.size)]) * wt[:, None]
        y = w * w * h * wt
        Ar = np.vstack([M.real, M.imag])
        yr = np.r_[y.real, y.imag]
        c, *_ = np.linalg.lstsq(Ar, yr, rcond=None)
        a, b = c[0], c[1]
        if not (a > 0 and b > 0):
            raise InputError(f"no resonance in the sweep at {level:g} N ({direction}): the steps "
                             f"{f.min():.4g}-{f.max():.4g} Hz do not bracket a mode", field="frfset")
        wr = math.sqrt(a)
        zeta = b / (2 * wr)
        sel = np.abs(f - wr / (2 * np.pi)) <= band * zeta * wr / (2 * np.pi) * 2
        if sel.sum() < 5:
            sel = np.argsort(np.abs(f - f[k]))[:min(f.size, 7)]
            sel = np.isin(np.arange(f.size), sel)
    r = Ar @ c - yr
    dof = max(yr.size - 4, 1)
    cov = np.linalg.pinv(Ar.T @ Ar) * float(r @ r) / dof
    sa, sb = math.sqrt(max(cov[0, 0], 0)), math.sqrt(max(cov[1, 1], 0))
    A = complex(c[2], c[3])
    Hr = abs(A) / (b * wr)                                 # |H(w_r)| = |A| / (b w_r)
    f_sd = sa / (2 * wr) / (2 * np.pi)
    z_sd = math.hypot(sb / (2 * wr), zeta * sa / (2 * a))
    X = Hr * force
    return BackbonePoint(X, wr / (2 * np.pi), zeta, "step_sine", X * math.hypot(sb / b, 0.5 * sa / a),
                         f_sd, z_sd, extra={"level_n": float(level), "direction": direction,
                                            "steps_fitted": int(sel.sum()) if hasattr(sel, "sum") else 0})


def measured_backbones(inputs: Iterable[str | Path], sensor: str | None = None,
                       modal_mass: float | None = None, ringdown_options: dict | None = None) -> list[Backbone]:
    """Backbones of run files and FRF set files by their kind: phase_resonance levels
    (one backbone), ringdown runs (two backbones each, ``ringdown_hilbert`` and
    ``ringdown_peaks``; the force removed with the levels' apparent modal mass when there
    are levels or ``modal_mass``), step_sine runs (one FRF set) and FRF set
    files (.json: a step-sine set by phase quadrature, a per-level broadband set by
    ``frf_levels``); a backbone file (``labjoint.backbone/1``, .json) gives its backbones.
    ``ringdown_options`` go to every ringdown's analysis (e.g. ``residual_compliance_m_per_n``,
    ``force_band``: :func:`labjoint.signal.ringdown.ringdown_backbone`)."""
    ropt = dict(ringdown_options or {})
    levels, rings, steps, sets = [], [], [], []
    stored: list[Backbone] = []
    for name in inputs:
        path = Path(name)
        if not path.exists():
            raise InputError("no such file", file=str(name))
        if path.suffix.lower() == ".json":
            if is_backbone_file(path):
                stored += load_backbones(path)[0]
            else:
                sets.append(FrfSet.load(path))
            continue
        with open_run(path) as rf:
            md = rf.metadata
        plan = md.get("plan")
        if plan == "phase_resonance":
            (rings if md.get("ringdown") else levels).append(path)
        elif plan == "step_sine":
            steps.append(path)
        else:
            raise InputError(f"not a phase_resonance, ringdown or step_sine run (plan {plan!r})",
                             file=str(name), field="plan")
    out: list[Backbone] = []
    mass = modal_mass
    pr = None
    if levels:
        pr = phase_resonance_backbone(levels, modal_mass_kg=modal_mass)
        if mass is None:
            mass = pr.points[0].extra["modal_mass_kg"]
    forces = {}
    for path in rings:
        with open_run(path) as rf:
            forces[path] = rf.metadata.get("force_channel")
    if pr is not None and modal_mass is None and rings and forces[rings[0]] is not None:
        # the slope's m_eff holds for a linear mode only: take the mass at which the
        # force-corrected ringdown meets the levels' frequencies (labjoint.identify.backbone_mass)
        got = mass_from_ringdown(pr, lambda m: ringdown_run_backbone(
            rings[0], sensor, force_channel=forces[rings[0]], modal_mass_kg=m, **ropt).by_method(), mass)
        if got is not None:
            mass = got[0]
            pr = phase_resonance_backbone(levels, modal_mass_kg=got[0], modal_mass_sd_kg=got[1],
                                          mass_note=got[2])
    if pr is not None:
        out.append(pr)
    for path in rings:
        fch = forces[path]
        use_force = mass is not None and fch is not None
        out += ringdown_run_backbone(path, sensor, force_channel=fch if use_force else None,
                                     modal_mass_kg=mass if use_force else None, **ropt).by_method()
    if steps:
        sets.append(frfset_from_runs(steps, sensors=[sensor] if sensor else None))
    out += [frf_levels_backbone(s, sensor) if is_broadband(s) else frfset_backbone(s, sensor) for s in sets]
    return stored + out
