"""Inputs of the stick-slip method, identified from runs (seed 002 section IV.A).

- Friction coefficient, seed 002 Eq. 10: mu = f_sld / f_n from a friction test in
  macro-slip (low frequency, low torque); f_sld is the sliding-plateau force of the
  loop, f_n = (torque-to-normal-force ratio, 478 N/Nm by default) x torque.
- Shear-layer stiffness K_t from the loop slope, seed 002 Eq. 9: K = 2 K_t.

Every value is an :class:`Identified`: value, standard uncertainty (cycle-to-cycle
scatter / sqrt(cycles), plus any stated input uncertainty) and the run it came from.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.identified import Identified
from labjoint.signal import validate
from labjoint.signal.clipping import refuse_clipped
from labjoint.signal.excitation import detect_excitation, require_sine
from labjoint.signal.filter import PAPER_CUTOFF_HZ, analysis_cutoff, lowpass
from labjoint.signal.frequency import estimate_frequency
from labjoint.signal.steady import detect_steady

STIFFNESS_METHODS = ("secant", "lsq")
#: Named in the refusal of a friction test that is not a steady sine.
FRICTION_PIPELINE = "the friction identification (seed 002 Eq. 10, labjoint friction)"
DEFAULT_TORQUE_TO_NORMAL_N_PER_NM = 478.0   # seed 002 section IV.A


def normal_force(torque_nm: float, ratio_n_per_nm: float = DEFAULT_TORQUE_TO_NORMAL_N_PER_NM
                 ) -> float:
    """Bolt normal force (N) from tightening torque (seed 002: 478 N/Nm)."""
    if not (np.isfinite(torque_nm) and torque_nm > 0):
        raise InputError(f"bolt torque must be positive, got {torque_nm} Nm", field="torque_nm")
    if not (np.isfinite(ratio_n_per_nm) and ratio_n_per_nm > 0):
        raise InputError(f"torque-to-normal-force ratio must be positive, got {ratio_n_per_nm}",
                         field="torque_to_normal_n_per_nm")
    return float(ratio_n_per_nm * torque_nm)


def _crossings(displacement: np.ndarray, sample_rate_hz: float, frequency_hz: float
               ) -> np.ndarray:
    """Sample indices of upward zero crossings of the centred record, chatter removed."""
    u = np.asarray(displacement, float)
    u = u - u.mean()
    period = sample_rate_hz / frequency_hz
    i = np.flatnonzero((u[:-1] < 0) & (u[1:] >= 0)) + 1
    if i.size:
        i = i[np.diff(i, prepend=-(10 * int(period) + 10)) >= 0.5 * period]
    return i


def cycle_labels(displacement: np.ndarray, sample_rate_hz: float, frequency_hz: float
                 ) -> np.ndarray:
    """Cycle index of every sample (-1 outside whole cycles), cut at upward zero crossings."""
    i = _crossings(displacement, sample_rate_hz, frequency_hz)
    labels = np.full(np.size(displacement), -1, np.int64)
    if i.size < 2:
        return labels
    labels[i[0]:i[-1]] = np.repeat(np.arange(i.size - 1), np.diff(i))
    return labels


def _per_cycle_mean(values: np.ndarray, labels: np.ndarray, mask: np.ndarray, n: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    m = mask & (labels >= 0)
    cnt = np.bincount(labels[m], minlength=n).astype(float)
    s = np.bincount(labels[m], weights=values[m], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return s / cnt, cnt


def _mean_sem(x: np.ndarray) -> tuple[float, float]:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float("nan"), float("nan")
    sem = float(np.std(x, ddof=1) / np.sqrt(x.size)) if x.size > 1 else float("nan")
    return float(np.mean(x)), sem


def loop_stiffness(displacement: np.ndarray, force: np.ndarray, sample_rate_hz: float,
                   frequency_hz: float, method: str = "lsq") -> tuple[np.ndarray, np.ndarray]:
    """Per-cycle loop stiffness (N/m) and amplitude U (m).

    ``lsq`` (default, as :mod:`labjoint.identify.loop`): least-squares slope of force on
    displacement over the cycle. seed 002 Eq. 9 defines K = F_i / u_i with F_i the
    force AT displacement u_i, so at u = U it is the slope to the force where the
    displacement peaks; for the fat loops the paper reports (W / (pi K U^2) ~ 0.4 in
    Table 2) that is the in-phase, least-squares slope, while peak force over peak
    displacement exceeds it by sqrt(1 + 0.4^2), 8 %.
    ``secant``: peak-to-peak force over peak-to-peak displacement (Fig. 2's F / U).
    """
    if method not in STIFFNESS_METHODS:
        raise InputError(f"stiffness method must be one of {STIFFNESS_METHODS}, got {method!r}",
                         field="stiffness_method")
    u = np.asarray(displacement, float)
    f = np.asarray(force, float)
    first = _crossings(u, sample_rate_hz, frequency_hz)
    if first.size < 2:
        raise InputError("record holds no whole cycle", field="displacement")
    um, fm = u[first[0]:first[-1]], f[first[0]:first[-1]]
    starts = first[:-1] - first[0]
    u_pp = np.maximum.reduceat(um, starts) - np.minimum.reduceat(um, starts)
    if method == "secant":
        f_pp = np.maximum.reduceat(fm, starts) - np.minimum.reduceat(fm, starts)
        k = f_pp / u_pp
    else:
        cnt = np.diff(first).astype(float)
        su, sf = np.add.reduceat(um, starts), np.add.reduceat(fm, starts)
        suu, suf = np.add.reduceat(um * um, starts), np.add.reduceat(um * fm, starts)
        k = (suf - su * sf / cnt) / (suu - su * su / cnt)
    return k, u_pp / 2


def shear_layer_stiffness(displacement: np.ndarray, force: np.ndarray, sample_rate_hz: float,
                          frequency_hz: float, *, source: str = "",
                          method: str = "lsq") -> Identified:
    """K_t = K_loop / 2 (seed 002 Eq. 9), mean over cycles, uncertainty = SEM."""
    k, amp = loop_stiffness(displacement, force, sample_rate_hz, frequency_hz, method)
    mean, sem = _mean_sem(k / 2)
    if not (np.isfinite(mean) and mean > 0):
        raise InputError(f"loop slope is not positive ({mean} N/m): check force sign/channels",
                         field="force")
    return Identified("shear_stiffness", mean, sem, "N/m", source, f"loop slope ({method}) / 2",
                      int(k.size), {"loop_stiffness_n_per_m": 2 * mean,
                                    "displacement_amplitude_m": float(np.mean(amp))})


def _cycle_starts(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First sample and length of every labelled cycle."""
    idx = np.flatnonzero(labels >= 0)
    lab = labels[idx]
    first = idx[np.flatnonzero(np.diff(lab, prepend=-1))]
    return first, np.bincount(lab)


def sliding_force(displacement: np.ndarray, force: np.ndarray, sample_rate_hz: float,
                  frequency_hz: float, *, rate_fraction: float = 0.15,
                  min_slip_fraction: float = 0.25, slide_fraction: float = 0.02
                  ) -> tuple[float, float, dict[str, Any]]:
    """Sliding force f_sld (N) of a macro-slip loop, with its standard uncertainty.

    f_sld is the level of the sliding plateau (Coulomb: the joint force while the whole
    contact slides, seed 002 Eq. 10), taken from the sliding samples themselves: those
    where the force hardly changes with displacement (|dF/du| below ``slide_fraction``
    of the stick stiffness, the loop's steep branch), away from the tips. Two things
    ride on a measured plateau and are fitted out, least squares over all cycles:

    - the force sensor's slow dynamics (a piezo or nanocomposite film's low-frequency
      roll-off, or AC coupling): with a time constant long against the period, the
      sensed force lags by kappa (G - mean G), G the running integral of the force
      over the cycle, so the plateau droops while it lasts (read at the tips, as
      before, it came out 2-3 % low on the simulated rig);
    - a velocity-proportional force (viscous), always (dropping one below 2 % of the
      plateau biased f_sld by up to 1.5 % while the SEM said 0.002 %).

    s F = f_sld - kappa s (G - mean G) + c s du/dt, s the sign of the plateau. The
    uncertainty combines the SEM of the per-cycle levels (with the common kappa and c)
    and the method's own: how far f_sld moves when the sliding samples are chosen with
    half and twice ``slide_fraction`` (the onset of sliding is where the fit's model is
    least exact); both are in the returned dict (``sliding_force_sem_n``,
    ``selection_uncertainty_n``). The joint must really
    slide: the flat samples (|dF/dt| below ``rate_fraction`` of the cycle's largest
    rate) must cover at least ``min_slip_fraction`` of the displacement travel, else
    InputError (micro-slip loops flatten only at their tips). The force at the tips
    and the plain plateau mean are reported as cross-checks.
    """
    u = np.asarray(displacement, float)
    f = np.asarray(force, float)
    if u.shape != f.shape:
        raise InputError(f"force has {f.size} samples, displacement {u.size}", field="force")
    lab = cycle_labels(u, sample_rate_hz, frequency_hz)
    n = int(lab.max()) + 1
    if n < 1:
        raise InputError("record holds no whole cycle", field="displacement")
    dfdt = np.gradient(f) * sample_rate_hz
    vel = np.gradient(u) * sample_rate_hz
    m = lab >= 0
    f_mid = _per_cycle_mean(f, lab, m, n)[0]
    safe = np.maximum(lab, 0)
    slip_fraction, flat = _slip_travel(u, f, lab, n, sample_rate_hz, rate_fraction)
    if not slip_fraction >= min_slip_fraction:
        raise InputError(
            f"no sliding plateau: the joint slid over only {slip_fraction:.0%} of its travel "
            f"(need {min_slip_fraction:.0%}); a friction test needs macro-slip "
            "(lower torque, lower frequency or higher amplitude, seed 002 IV.A)",
            field="force")
    first, length = _cycle_starts(lab)
    win = int(length.min())
    rows = first[:, None] + np.arange(win)[None, :]
    tip_hi = f[first + np.argmax(u[rows], axis=1)]
    tip_lo = f[first + np.argmin(u[rows], axis=1)]
    f_up = _per_cycle_mean(f, lab, flat & (f > f_mid[safe]), n)[0]
    f_lo = _per_cycle_mean(f, lab, flat & (f < f_mid[safe]), n)[0]
    levels, fit = _plateau_fit(f, vel, dfdt, lab, n, f_mid, sample_rate_hz, slide_fraction)
    mean, sem = _mean_sem(levels)
    shifts = [0.0]
    for alt in (0.5 * slide_fraction, 2.0 * slide_fraction):
        try:
            alt_levels = _plateau_fit(f, vel, dfdt, lab, n, f_mid, sample_rate_hz, alt)[0]
        except InputError:            # too few samples at half the threshold: no shift seen
            continue
        shifts.append(abs(_mean_sem(alt_levels)[0] - mean))
    sel = float(np.nanmax(shifts))
    total = float(np.hypot(sem, sel)) if np.isfinite(sem) else sel
    return mean, total, {"slip_fraction": slip_fraction, "cycles": int(np.isfinite(levels).sum()),
                       "sliding_force_sem_n": sem, "selection_uncertainty_n": sel,
                       "offset_n": float(np.nanmean((tip_hi + tip_lo) / 2)),
                       "tip_force_n": float(np.nanmean((tip_hi - tip_lo) / 2)),
                       "plateau_mean_n": float(np.nanmean((f_up - f_lo) / 2)), **fit}


def _slip_travel(u: np.ndarray, f: np.ndarray, lab: np.ndarray, n: int, fs: float,
                 rate_fraction: float) -> tuple[float, np.ndarray]:
    """Median over cycles of the share of the displacement travel made on a plateau
    (|dF/dt| below ``rate_fraction`` of the cycle's largest force rate), and the mask of
    those flat samples."""
    dfdt = np.abs(np.gradient(f)) * fs
    dudt = np.abs(np.gradient(u)) * fs
    m = lab >= 0
    rate_max = np.zeros(n)
    np.maximum.at(rate_max, lab[m], dfdt[m])
    flat = m & (dfdt < rate_fraction * rate_max[np.maximum(lab, 0)])
    travel_flat = np.bincount(lab[flat], weights=dudt[flat], minlength=n)
    travel = np.bincount(lab[m], weights=dudt[m], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return float(np.nanmedian(travel_flat / travel)), flat


def _plateau_fit(f: np.ndarray, vel: np.ndarray, dfdt: np.ndarray, lab: np.ndarray, n: int,
                 f_mid: np.ndarray, fs: float, slide_fraction: float
                 ) -> tuple[np.ndarray, dict[str, Any]]:
    """Per-cycle plateau levels and the fitted sensor-lag and viscous terms (see
    :func:`sliding_force`)."""
    sign, drift, speed, target, cyc = [], [], [], [], []
    for c in range(n):
        idx = np.flatnonzero(lab == c)
        y = f[idx] - f_mid[c]
        g = np.cumsum(y) / fs
        g -= g.mean()
        v = vel[idx]
        moving = np.abs(v) > 0.2 * np.abs(v).max()
        with np.errstate(divide="ignore", invalid="ignore"):
            dfdu = np.abs(dfdt[idx] / v)
        if not moving.any():
            continue
        k_stick = np.percentile(dfdu[moving], 95)
        sel = moving & (dfdu < slide_fraction * k_stick)
        s = np.sign(y[sel])
        sign.append(s)
        drift.append(s * g[sel])
        speed.append(s * v[sel])
        target.append(s * y[sel])
        cyc.append(np.full(s.size, c))
    if not target or sum(t.size for t in target) < 8:
        raise InputError("no sliding samples: the force never stays level while the joint "
                         "moves (a friction test needs macro-slip, seed 002 IV.A)", field="force")
    g, v, y, cy = (np.concatenate(a) for a in (drift, speed, target, cyc))
    X = np.stack([np.ones_like(g), g, v], axis=1)
    coef = np.linalg.lstsq(X, y, rcond=None)[0]
    resid_level = y - X[:, 1:] @ coef[1:]                     # each sample's plateau level
    cnt = np.bincount(cy, minlength=n).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        levels = np.bincount(cy, weights=resid_level, minlength=n) / cnt
    return levels, {"sensor_lag_per_s": float(-coef[1]),
                    "plateau_viscous_ns_per_m": float(coef[2]),
                    "sliding_samples": int(y.size)}


def friction_coefficient(displacement: np.ndarray, force: np.ndarray, sample_rate_hz: float,
                         frequency_hz: float, normal_force_n: float, *, source: str = "",
                         normal_force_rel_uncertainty: float = 0.0,
                         force_rel_uncertainty: float = 0.0) -> Identified:
    """mu = f_sld / f_n (seed 002 Eq. 10) from a macro-slip friction-test record.

    The uncertainty combines that of f_sld (cycle-to-cycle SEM and the sliding-sample
    selection, :func:`sliding_force`) with the stated relative uncertainties of the
    normal force (torque ratio) and of the force calibration.
    """
    if not (np.isfinite(normal_force_n) and normal_force_n > 0):
        raise InputError(f"normal force must be positive, got {normal_force_n} N",
                         field="normal_force_n")
    f_sld, u_f, info = sliding_force(displacement, force, sample_rate_hz, frequency_hz)
    mu = f_sld / normal_force_n
    rel = np.sqrt((u_f / f_sld) ** 2 + normal_force_rel_uncertainty ** 2
                  + force_rel_uncertainty ** 2)
    info.update(sliding_force_n=f_sld, sliding_force_uncertainty_n=u_f,
                normal_force_n=normal_force_n)
    return Identified("friction_coefficient", float(mu), float(abs(mu) * rel), "1", source,
                      "seed 002 Eq. 10: sliding plateau / normal force", info["cycles"], info)


def steady_span(displacement: np.ndarray, sample_rate_hz: float, frequency_hz: float,
                rel_tol: float = 0.01) -> slice:
    """Samples of the steady whole cycles (per-cycle amplitude settled, signal.detect_steady)."""
    u = np.asarray(displacement, float)
    lab = cycle_labels(u, sample_rate_hz, frequency_hz)
    if lab.max() < 2:
        raise InputError(f"holds fewer than 3 whole cycles at {frequency_hz:g} Hz",
                         field="displacement")
    first, _ = _cycle_starts(lab)
    m = lab >= 0
    amp = (np.maximum.reduceat(u[m], first - first[0]) - np.minimum.reduceat(u[m], first - first[0])) / 2
    st = detect_steady(amp, rel_tol=rel_tol)
    stop = first[st.stop] if st.stop < first.size else int(np.flatnonzero(m)[-1]) + 1
    return slice(int(first[st.start]), int(stop))


#: Run-metadata key of the torque-to-normal-force ratio (written by the run engine).
RATIO_KEY = "torque_to_normal_n_per_nm"


def run_normal_force(md: dict[str, Any], torque_to_normal_n_per_nm: float | None = None
                     ) -> float:
    """Bolt normal force (N) of a run from its metadata.

    A given ``torque_to_normal_n_per_nm`` overrides the file: ``torque_nm`` x it.
    Otherwise the run's ``normal_force_n``, else ``torque_nm`` x the run's
    ``torque_to_normal_n_per_nm`` (seed 002's 478 N/Nm if absent).
    """
    torque = md.get("torque_nm")
    if torque_to_normal_n_per_nm is None:
        n = md.get("normal_force_n")
        if n is not None:
            return float(n)
        ratio = float(md.get(RATIO_KEY) or DEFAULT_TORQUE_TO_NORMAL_N_PER_NM)
    else:
        ratio = float(torque_to_normal_n_per_nm)
    if torque is None:
        raise InputError("run gives neither normal_force_n nor torque_nm" if
                         torque_to_normal_n_per_nm is None else
                         "a torque-to-normal ratio needs the run's torque_nm", field="torque_nm")
    return normal_force(float(torque), ratio)


def identify_friction(run: Any, *, torque_to_normal_n_per_nm: float | None = None,
                      cutoff_hz: float | None = PAPER_CUTOFF_HZ,
                      normal_force_rel_uncertainty: float = 0.0,
                      force_rel_uncertainty: float = 0.0) -> Identified:
    """seed 002 Eq. 10 on a friction-test run (macro-slip, e.g. 100 Hz and 2 Nm).

    The force is the run's joint force (the nanocomposite sensor through its
    calibration at the run's frequency); the normal force comes from the run's metadata
    (:func:`run_normal_force`: ``normal_force_n``, else ``torque_nm`` x the run's
    ``torque_to_normal_n_per_nm``); a given ``torque_to_normal_n_per_nm`` overrides
    it as ``torque_nm`` x that ratio. Steady cycles only, low-passed as in seed 002
    (3 kHz).
    """
    md = run.metadata
    n = run_normal_force(md, torque_to_normal_n_per_nm)
    fs = run.sample_rate_hz
    u = validate.signal(run.displacement, "displacement", min_samples=16)
    F = validate.signal(run.force, "force", min_samples=16)
    validate.same_length(F, u, "force", "displacement")
    # a clipped force looks like a sliding plateau; a clipped displacement (the rig's
    # probes at their range in gross slip) still marks the cycles and the slip direction
    refuse_clipped(F, "force", reference=u, what="its sliding force and friction coefficient")
    x = F if getattr(run, "excitation", None) is None else run.excitation
    require_sine(detect_excitation(x, fs), FRICTION_PIPELINE, f"run {run.name}")
    f = run.frequency_hz or estimate_frequency(u, fs, min_hz=3.0 * fs / u.size)
    cutoff, _ = analysis_cutoff(fs, cutoff_hz)
    if cutoff is not None:
        u, F = lowpass(u - u.mean(), fs, cutoff), lowpass(F - F.mean(), fs, cutoff)
    span = steady_span(u, fs, f)
    return friction_coefficient(u[span], F[span], fs, f, float(n), source=run.name,
                                normal_force_rel_uncertainty=normal_force_rel_uncertainty,
                                force_rel_uncertainty=force_rel_uncertainty)


# ---- where identified inputs are kept -------------------------------------------------
