"""Stick-slip-boundary identification, seed 002 section II.B (Eqs. 4-9), vectorised.

For each rising quarter cycle u_1 = 0 < u_2 < ... < u_n = U (Eq. 5):

- Eq. 6: mu int_{c_i}^a sigma 2 pi r dr = K_t u_i  ->  stick-slip boundary c_i
  (closed-form polynomial integral; all samples at once by a table uniform in
  sqrt(load) plus one Newton step, numba, see :mod:`.contact`);
  c_i stays in the contact zone; K_t u_i above the whole patch's friction force
  mu int sigma dA flags macro-slip and clamps c_i to the inner radius.
- Eq. 7: W_di = 4 (2 pi mu du_i int_{c_i}^a sigma r dr) = 4 du_i f_sld(c_i), summed over
  the quarter: the Riemann sum of W(u) = 4 int_0^u f_sld ds. It is integrated exactly
  here, with f_sld(s) = K_t s (Eq. 6) up to the macro-slip limit u* = f_max / K_t and
  f_max = mu int sigma dA beyond: W(u) = 2 K_t u^2 (u <= u*), 2 K_t u*^2 + 4 f_max (u - u*)
  (u > u*). The paper's sum takes f_sld at the end of each step, which adds about
  (pi/4)(2 pi f / fs) relative (3-4 % at 50 kS/s, 400 Hz) and makes W depend on the
  sample rate; the integral does not.
- Eq. 8: C_i = W(u_i) / (pi omega u_i^2); C_1 = 0 (no sliding at u = 0). Eq. 9: K_i = F_i /
  u_i with F_i = f_stk + f_sld = 2 K_t u_i while part of the contact sticks (Eqs. 4, 6); in
  macro-slip (c_i at the inner radius) the whole contact carries f_max: K_i = f_max / u_i.
- U = u_n (Eq. 5): the band-limited cycle's half peak-to-peak (harmonic fit, each cycle
  on its own one-period mean: a sliding joint drifts; :func:`~.quarters.band_limited_peaks`),
  not the largest sample (short by up to 1 - cos(pi f / fs): 2.4 % in W at 20 per cycle).

What these numbers are (model values, not measurements): while no macro-slip occurs,
Eq. 6 makes f_sld = K_t u exactly, so W = 2 K_t U^2 and C = W / (pi omega U^2) =
2 K_t / (pi omega) = K / (pi omega) with K = 2 K_t (Eq. 9), whatever mu and the pressure
law are (they only set c(u) and the macro-slip limit): with K_t from the loop, their
closeness to the loop's W and C is not an independent confirmation. Every stick-slip C
in seed 002's Tables 2-4 equals 1.031 K / (pi omega): its right-endpoint sum
(1 + (pi/4) 2 pi f / fs at about 160 samples per cycle) times the exact K / (pi omega).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.contact import ContactPressure
from labjoint.identify.friction import (DEFAULT_TORQUE_TO_NORMAL_N_PER_NM, RATIO_KEY, normal_force,
                                        shear_layer_stiffness)
from labjoint.identify.identified import Identified
from labjoint.identify.quarters import band_limited_peaks, period_mean, rising_quarters
from labjoint.identify.sliding import MACRO_SLIP_TRAVEL, slip_travel_fraction, stick_branch_stiffness
from labjoint.identify.stickslip_curves import (MAX_FRICTION, MIN_FRICTION, QuarterCurves,  # noqa: F401
                                              check_friction, stick_slip_curves)
from labjoint.signal import validate
from labjoint.signal.clipping import refuse_clipped
from labjoint.signal.excitation import detect_excitation, require_sine
from labjoint.signal.filter import PAPER_CUTOFF_HZ, analysis_cutoff, lowpass
from labjoint.signal.frequency import estimate_frequency
from labjoint.signal.steady import detect_steady


#: What the stick-slip numbers are, carried in every result (CLI, JSON, page).
BASIS = ("model-based: seed 002 Eqs. 6-9 with K_t, mu and the contact law; in micro-slip "
         "W = 2 K_t U^2 and C = K / (pi omega) with K = 2 K_t, so they follow from K_t "
         "(the loop slope), U and omega and do not measure dissipation independently")

# ---- the pipeline on a run ------------------------------------------------------------

#: Bolt radius used when neither the caller nor the run metadata gives one (M10, as the
#: simulated rig). With sigma_s normalised to N it changes c(u) only, never W or C.
DEFAULT_BOLT_RADIUS_M = 5e-3
#: Run-metadata keys read for the contact geometry (SI), if present.
GEOMETRY_KEYS = {"bolt_radius_m": "bolt_radius_m", "contact_radius_m": "contact_radius_m",
                 "inner_radius_m": "contact_inner_radius_m", "head_radius_m": "bolt_head_radius_m"}
SUMMARY_KEYS = ("displacement_amplitude_m", "energy_loss_j", "damping_ns_per_m",
                "min_boundary_radius_m")


def _as_identified(value: Any, name: str, unit: str, field: str) -> Identified:
    if isinstance(value, Identified):
        return value
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"must be a number or an Identified value, got {value!r}",
                         field=field) from None
    return Identified(name, v, 0.0, unit, "given", "given by the caller")


@dataclass
class StickSlipResult:
    """The stick-slip pipeline's output for one run (all SI).

    ``curves``: Eqs. 6-9 along every rising quarter; ``steady``: which quarters are
    steady; ``summary``: mean and std over steady quarters; ``representative``: index
    of the steady quarter whose energy loss is the median (its curves are stored).
    """

    run: str
    frequency_hz: float
    contact: ContactPressure
    friction: Identified
    shear_stiffness: Identified
    curves: QuarterCurves
    steady: np.ndarray
    representative: int
    summary: dict[str, Any] = field(default_factory=dict)

    def curve(self) -> dict[str, np.ndarray]:
        """c(u), W(u), C(u) (and f_sld, K, macro-slip) of the representative quarter."""
        return self.curves.quarter(self.representative)

    def processed(self) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
        """(arrays, attrs, units) for ``labjoint.storage.write_processed(path, "stickslip", ...)``."""
        c = self.curve()
        tot = self.curves.totals()
        arrays = {
            "displacement": c["displacement_m"], "boundary_radius": c["boundary_radius_m"],
            "energy_loss": c["energy_loss_j"], "damping": c["damping_ns_per_m"],
            "sliding_force": c["sliding_force_n"], "stiffness": c["stiffness_n_per_m"],
            "macro_slip": c["macro_slip"].astype(np.int8),
            "quarter_amplitude": tot["displacement_amplitude_m"],
            "quarter_energy_loss": tot["energy_loss_j"],
            "quarter_damping": tot["damping_ns_per_m"], "quarter_steady": self.steady.astype(np.int8),
        }
        units = {"displacement": "m", "boundary_radius": "m", "energy_loss": "J",
                 "damping": "N*s/m", "sliding_force": "N", "stiffness": "N/m",
                 "quarter_amplitude": "m", "quarter_energy_loss": "J", "quarter_damping": "N*s/m"}
        cp = self.contact
        attrs = {"method": "seed 002 II.B stick-slip boundary (Eqs. 2-9)",
                 "summary": self.summary, "friction_coefficient": self.friction.to_dict(),
                 "shear_stiffness": self.shear_stiffness.to_dict(),
                 "contact": {"bolt_radius_m": cp.bolt_radius_m, "contact_radius_m": cp.a,
                             "inner_radius_m": cp.inner, "sigma_s_pa": cp.sigma_s,
                             "sigma_s_mode": cp.sigma_s_mode, "normal_force_n": cp.normal_force_n,
                             "head_stress_force_ratio": cp.force_ratio},
                 "representative_quarter": int(self.representative)}
        return arrays, attrs, units


class StickSlipIdentifier:
    """seed 002 II.B on a record: low-pass, rising quarters, Eqs. 6-9, steady mean.

    Settings only: ``friction_coefficient`` (float or :class:`Identified`, e.g. from
    :func:`labjoint.identify.friction.friction_coefficient`); ``shear_stiffness``
    K_t (None: identified from the same run's loop slope, K_t = K / 2, Eq. 9, with
    ``stiffness_method``); contact geometry (None: run metadata, else defaults);
    ``torque_to_normal_n_per_nm`` when the run gives only a torque (None: the run's
    metadata ``torque_to_normal_n_per_nm``, else seed 002's 478 N/Nm).
    ``loop_slope``: K_t from the loop method's slope, used unless the loop slides as a
    whole; such a loop gets K_t from its stick branches (:mod:`labjoint.identify.sliding`).
    After :meth:`fit`, ``result_`` holds a :class:`StickSlipResult`.
    """

    def __init__(self, friction_coefficient: float | Identified,
                 shear_stiffness: float | Identified | None = None, *,
                 bolt_radius_m: float | None = None, contact_radius_m: float | None = None,
                 inner_radius_m: float | None = None, head_radius_m: float | None = None,
                 sigma_s_mode: str = "force", torque_to_normal_n_per_nm: float | None = None,
                 stiffness_method: str = "lsq", cutoff_hz: float | None = PAPER_CUTOFF_HZ,
                 rel_tol: float = 0.01, loop_slope: float | Identified | None = None) -> None:
        self.friction_coefficient, self.loop_slope = friction_coefficient, loop_slope
        self.shear_stiffness = shear_stiffness
        self.bolt_radius_m, self.contact_radius_m = bolt_radius_m, contact_radius_m
        self.inner_radius_m, self.head_radius_m = inner_radius_m, head_radius_m
        self.sigma_s_mode = sigma_s_mode
        self.torque_to_normal_n_per_nm = torque_to_normal_n_per_nm
        self.stiffness_method = stiffness_method
        self.cutoff_hz = cutoff_hz
        self.rel_tol = rel_tol

    def fit(self, run: Any) -> "StickSlipIdentifier":
        """Identify from a :class:`labjoint.storage.run.Run` (SI units)."""
        return self.fit_arrays(run.displacement, run.force, run.sample_rate_hz,
                               run.frequency_hz, name=run.name, metadata=run.metadata)

    def _contact(self, md: dict[str, Any]) -> ContactPressure:
        n = md.get("normal_force_n")
        if n is None or not np.isfinite(float(n)) or float(n) <= 0:
            torque = md.get("torque_nm")
            if torque is None:
                raise InputError("run gives neither normal_force_n nor torque_nm",
                                 field="torque_nm")
            ratio = self.torque_to_normal_n_per_nm
            if ratio is None:   # the run's ratio (engine metadata), else seed 002's 478 N/Nm
                ratio = float(md.get(RATIO_KEY) or DEFAULT_TORQUE_TO_NORMAL_N_PER_NM)
            n = normal_force(float(torque), ratio)
        geo = {}
        for attr, key in GEOMETRY_KEYS.items():
            v = getattr(self, attr)
            geo[attr] = v if v is not None else md.get(key)
        if geo["bolt_radius_m"] is None:
            geo["bolt_radius_m"] = DEFAULT_BOLT_RADIUS_M
        return ContactPressure(normal_force_n=float(n), sigma_s_mode=self.sigma_s_mode, **geo)

    def fit_arrays(self, displacement: np.ndarray, force: np.ndarray | None,
                   sample_rate_hz: float, frequency_hz: float | None, *, name: str = "",
                   metadata: dict[str, Any] | None = None) -> "StickSlipIdentifier":
        """Identify from arrays: relative displacement (m), joint force (N, for K_t)."""
        md = dict(metadata or {})
        fs = validate.sample_rate(sample_rate_hz, "sample_rate_hz")
        u = validate.signal(displacement, "displacement", min_samples=16)
        mu = _as_identified(self.friction_coefficient, "friction_coefficient", "1",
                            "friction_coefficient")
        contact = self._contact(md)
        refuse_clipped(u, "displacement", what="its stick-slip boundary and energy loss")
        if u.size >= 256:                # shorter: left to the quarter-cycle checks
            require_sine(detect_excitation(u if force is None else force, fs),
                         "the stick-slip method (seed 002 Eqs. 2-9)", name or "the record")
        f = (float(frequency_hz) if frequency_hz is not None
             else estimate_frequency(u, fs, min_hz=3.0 * fs / u.size))
        f = validate.positive(f, "frequency_hz")
        cutoff, _rule = analysis_cutoff(fs, self.cutoff_hz)
        u = u - u.mean()
        uf = lowpass(u, fs, cutoff) if cutoff is not None else u
        uf = uf - period_mean(uf, fs, f)       # u_i from each cycle's centre, drift removed
        q = rising_quarters(uf, fs, f)
        if q.starts.size < 2:
            raise InputError(f"holds {q.starts.size} rising quarter cycles at {f:g} Hz; "
                             "need at least 2", field="displacement")
        ends = np.append(q.starts[1:], q.displacement_m.size) - 1
        # u_n = U of Eq. 5 band-limited, not the largest sample (rate-independent W)
        q.displacement_m[ends] = band_limited_peaks(uf, q.peak_sample, fs, f, cutoff,
                                                    half_range=True)
        steady = detect_steady(q.displacement_m[ends], rel_tol=self.rel_tol).mask
        if not steady.any():
            raise InputError("no steady quarter cycles", field="displacement")
        if self.shear_stiffness is None:
            if force is None:
                raise InputError("K_t must be given when no force is recorded",
                                 field="shear_stiffness")
            F = validate.signal(force, "force", min_samples=16)
            validate.same_length(F, u, "force", "displacement")
            refuse_clipped(F, "force", reference=u, what="its shear-layer stiffness K_t")
            k = np.flatnonzero(steady)
            a = int(np.floor(q.crossing_sample[k[0]]))
            b = int(min(u.size, np.ceil(q.crossing_sample[k[-1]] + fs / f) + 1))
            Ff = lowpass(F - F.mean(), fs, cutoff) if cutoff is not None else F - F.mean()
            src = name or "record"
            if slip_travel_fraction(uf[a:b], Ff[a:b], fs, f) >= MACRO_SLIP_TRAVEL:  # slides
                kt = stick_branch_stiffness(uf[a:b], Ff[a:b], fs, f, source=src)
            elif self.loop_slope is not None:
                kt = _as_identified(self.loop_slope, "shear_stiffness", "N/m", "loop_slope")
            else:
                kt = shear_layer_stiffness(uf[a:b], Ff[a:b], fs, f, source=src,
                                           method=self.stiffness_method)
        else:
            kt = _as_identified(self.shear_stiffness, "shear_stiffness", "N/m", "shear_stiffness")
        curves = stick_slip_curves(q.displacement_m, q.starts, shear_stiffness_n_per_m=kt.value,
                                   friction_coefficient=mu.value, contact=contact,
                                   frequency_hz=f)
        tot = curves.totals()
        n_st = int(steady.sum())
        ddof = 1 if n_st > 1 else 0
        summary: dict[str, Any] = {"frequency_hz": f}
        for key in SUMMARY_KEYS:
            vals = tot[key][steady]
            summary[key] = float(np.mean(vals))
            summary[key + "_std"] = float(np.std(vals, ddof=ddof))
        k_end = curves.stiffness_n_per_m[curves.ends][steady]      # K at u = U (Eq. 9)
        summary.update(stiffness_n_per_m=float(np.mean(k_end)),
                       stiffness_n_per_m_std=float(np.std(k_end, ddof=ddof)),
                       macro_slip_fraction=float(np.mean(tot["macro_slip"][steady])),
                       cycles=n_st, friction_coefficient=mu.value,
                       shear_stiffness_n_per_m=kt.value,
                       shear_stiffness_method=kt.method, basis=BASIS)
        w = tot["energy_loss_j"]
        idx = np.flatnonzero(steady)
        rep = int(idx[np.argsort(w[idx])[idx.size // 2]])
        self.result_ = StickSlipResult(name, f, contact, mu, kt, curves, steady, rep, summary)
        return self
