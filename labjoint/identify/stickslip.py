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
from numba import njit

from labjoint.errors import InputError
from labjoint.identify.contact import ContactPressure, horner, invert_loads
from labjoint.identify.friction import (DEFAULT_TORQUE_TO_NORMAL_N_PER_NM, RATIO_KEY, normal_force,
                                        shear_layer_stiffness)
from labjoint.identify.identified import Identified
from labjoint.identify.quarters import band_limited_peaks, period_mean, rising_quarters
from labjoint.identify.sliding import MACRO_SLIP_TRAVEL, slip_travel_fraction, stick_branch_stiffness
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

#: Friction coefficients taken: far below (above) any dry contact's (mu -> 0: Eq. 6 overflows)
MIN_FRICTION, MAX_FRICTION = 1e-3, 5.0


def check_friction(mu: float, field: str = "friction_coefficient") -> float:
    """``mu`` as a float if it is a friction coefficient a contact can have, else InputError."""
    mu = float(mu)
    if not (np.isfinite(mu) and MIN_FRICTION <= mu <= MAX_FRICTION):
        raise InputError(f"friction coefficient must be between {MIN_FRICTION:g} and "
                         f"{MAX_FRICTION:g}, got {mu:g}", field=field)
    return float(mu)


def _check_inputs(k_t: float, mu: float, frequency_hz: float) -> None:
    check_friction(mu)
    if not (np.isfinite(k_t) and k_t > 0):
        raise InputError(f"shear-layer stiffness K_t must be positive, got {k_t} N/m",
                         field="shear_stiffness_n_per_m")
    if not (np.isfinite(frequency_hz) and frequency_hz > 0):
        raise InputError(f"excitation frequency must be positive, got {frequency_hz} Hz",
                         field="frequency_hz")


@dataclass
class QuarterCurves:
    """Eqs. 6-9 along one or more rising quarter cycles, stored flat.

    Quarter k occupies ``[starts[k], starts[k+1])`` of every per-sample array
    (``starts`` has one more entry than there are quarters). Units: m, J, N s/m, N/m, N.
    """

    displacement_m: np.ndarray
    boundary_radius_m: np.ndarray
    sliding_force_n: np.ndarray
    energy_loss_j: np.ndarray        # cumulative: W(u_i) = sum_{k<=i} W_dk, full cycle
    damping_ns_per_m: np.ndarray
    stiffness_n_per_m: np.ndarray
    macro_slip: np.ndarray
    starts: np.ndarray

    @property
    def n_quarters(self) -> int:
        return len(self.starts) - 1

    @property
    def ends(self) -> np.ndarray:
        """Index of each quarter's last sample (u_n = U)."""
        return self.starts[1:] - 1

    def quarter(self, k: int) -> dict[str, np.ndarray]:
        """The curves of quarter ``k`` as a dict of arrays."""
        sl = slice(int(self.starts[k]), int(self.starts[k + 1]))
        return {name: getattr(self, name)[sl] for name in
                ("displacement_m", "boundary_radius_m", "sliding_force_n", "energy_loss_j",
                 "damping_ns_per_m", "stiffness_n_per_m", "macro_slip")}

    def totals(self) -> dict[str, np.ndarray]:
        """Per quarter: amplitude U, energy loss per cycle W, damping C, macro-slip flag."""
        e = self.ends
        macro = np.logical_or.reduceat(self.macro_slip, self.starts[:-1]) \
            if self.n_quarters else np.zeros(0, bool)
        return {"displacement_amplitude_m": self.displacement_m[e],
                "energy_loss_j": self.energy_loss_j[e],
                "damping_ns_per_m": self.damping_ns_per_m[e],
                "min_boundary_radius_m": self.boundary_radius_m[e],
                "macro_slip": macro}


def stick_slip_curves(displacement_m: np.ndarray, starts: np.ndarray | None, *,
                      shear_stiffness_n_per_m: float, friction_coefficient: float,
                      contact: ContactPressure, frequency_hz: float) -> QuarterCurves:
    """Eqs. 6-9 on rising quarter cycles given flat; each must start at u_1 = 0 (Eq. 5).

    ``starts``: first index of each quarter in ``displacement_m`` (None: one quarter).
    The example is seed 002's reference case: K = 2 K_t = 11.8 MN/m, U = 7.4 um, 400 Hz:
    W = 2 K_t U^2 and C = K / (pi omega) exactly, at any sampling (Table 2's 0.672 mJ and
    1542 Ns/m are its right-endpoint sums, 1.03-1.04 times these).

    >>> cp = ContactPressure(bolt_radius_m=4e-3, normal_force_n=2390.0)
    >>> u = 7.4e-6 * np.sin(np.linspace(0, np.pi / 2, 32))
    >>> q = stick_slip_curves(u, None, shear_stiffness_n_per_m=5.9e6,
    ...                       friction_coefficient=0.168, contact=cp, frequency_hz=400.0)
    >>> W, C = float(q.energy_loss_j[-1]), float(q.damping_ns_per_m[-1])
    >>> round(W * 1e3, 4), round(C / (11.8e6 / (np.pi * 2 * np.pi * 400)), 9)
    (0.6462, 1.0)
    """
    k_t, mu = float(shear_stiffness_n_per_m), float(friction_coefficient)
    _check_inputs(k_t, mu, frequency_hz)
    u = np.ascontiguousarray(displacement_m, dtype=float)
    n = u.size
    starts = np.array([0, n] if starts is None else np.append(starts, n), dtype=np.int64)
    if n == 0 or np.any(np.diff(starts) < 1) or starts[0] != 0:
        raise InputError("quarter-cycle starts must be increasing indices from 0",
                         field="starts")
    # Eq. 6 -> y_i = (c_i / r_b)^2 for every sample at once; macro-slip when K_t u_i
    # exceeds mu * (whole-patch load): c_i then clamps to the inner radius.
    y = np.empty(n)
    macro = np.empty(n, dtype=np.bool_)
    table, meta, coefs = contact.solver_arrays()
    invert_loads(k_t * u / (mu * contact.load_scale), table, meta, coefs, 1, y, macro)
    c = np.where(u > 0, contact.bolt_radius_m * np.sqrt(y), contact.a)
    out = np.empty((4, n))
    _eqs_7_to_9(u, starts, y, coefs, meta[2], mu * contact.load_scale, k_t,
                mu * contact.total_force, 2.0 * np.pi * frequency_hz, out)
    f_sld, w, damping, stiffness = out
    return QuarterCurves(u, c, f_sld, w, damping, stiffness, macro, starts)


@njit(cache=True)
def _eqs_7_to_9(u, starts, y, coefs, g_top, mu_scale, k_t, f_max, omega, out):  # pragma: no cover
    """Per sample: f_sld (Eq. 3 at c_i), W (Eq. 7 integrated exactly), C (Eq. 8), K (Eq. 9)."""
    u_star = f_max / k_t                                       # macro-slip from here on
    for i in range(u.size):
        g = 0.0
        if u[i] > 0.0:
            g = g_top - horner(coefs, 7, 14, y[i])
        f_sld = mu_scale * g                                   # Eq. 3
        x = max(u[i], 0.0)
        if x <= u_star:                                        # 4 int_0^x K_t s ds
            w = 2.0 * k_t * x * x
        else:                                                  # + 4 f_max (x - u*)
            w = 2.0 * k_t * u_star * u_star + 4.0 * f_max * (x - u_star)
        out[0, i] = f_sld
        out[1, i] = w
        if x > 0.0:
            out[2, i] = w / (np.pi * omega * x * x)            # Eq. 8
            if x <= u_star:
                out[3, i] = 2.0 * k_t                          # Eq. 9: (K_t u + K_t u) / u
            else:
                out[3, i] = f_max / x                          # all slides: f_max, once
        else:
            out[2, i] = 0.0
            out[3, i] = 2.0 * k_t


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
