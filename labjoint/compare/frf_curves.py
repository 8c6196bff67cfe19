"""Model FRFs evaluated densely beside the measured steps (issue 32 item 7: the page's
structure view draws the model as a curve, not as a polyline through the steps).

For each sweep of the ``frf`` kind (a force level, a direction, the steps around one
mode: :mod:`labjoint.compare.kinds.frf`) the joint model with given parameters is solved
by harmonic balance on the Craig-Bampton reduced structure the comparison uses, on a
fine grid of ``points`` frequencies that spans the sweep's steps and ``margin`` of their
span on either side, in the sweep's direction, each frequency from the previous one's
solution (:func:`labjoint.structure.frf.response_at`: continuation in frequency, a step
sine's branch through a jump). The force amplitude along the grid is the achieved force
of the steps interpolated in frequency (held at the end values outside them), so the
curve passes through the model's values at the steps. A frequency where harmonic balance
does not converge is left out (null) and listed.

Per sweep, sensor and harmonic h, measured and model are given as magnitude per newton
(|response_h| / |F|, in the set's quantity: m/s^2/N, m/s/N or m/N) and phase relative to
the force (arg response_h - h arg F, degrees in (-180, 180]), as the comparison's
residuals see them (:class:`labjoint.structure.predict.FrfPredictor`). A model harmonic
below ``ROUNDOFF`` of the sensor's harmonic-1 peak is given as magnitude 0 and phase null
(the solver's round-off, not a response).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from labjoint.compare.frf_api import load_frf
from labjoint.compare.jsonsafe import clean
from labjoint.compare.kinds.frf import FrfMeasurement
from labjoint.errors import InputError
from labjoint.structure.frf import response_at
from labjoint.structure.joint import check_structure_law
from labjoint.structure.law import JointLaw
from labjoint.structure.predict import convert

DEFAULT_POINTS, MAX_POINTS, MIN_POINTS = 200, 1000, 20
DEFAULT_MARGIN = 0.25
#: a model harmonic below this fraction of the sensor's harmonic-1 peak is round-off of
#: the solver (a linear or odd law has no even harmonics): magnitude 0, phase null
ROUNDOFF = 1e-9
UNITS = {"acceleration": "m/s^2/N", "velocity": "m/s/N", "displacement": "m/N"}


def grid(m: FrfMeasurement, points: int, margin: float) -> np.ndarray:
    """``points`` frequencies (Hz) over the sweep's steps and ``margin`` x their span on
    either side (at least 1 % of the mid frequency in all), in the sweep's direction."""
    f = m.frfset.frequencies_hz
    lo, hi = float(f.min()), float(f.max())
    pad = max(margin * (hi - lo), 0.005 * (lo + hi) / 2)
    g = np.linspace(max(lo - pad, 1e-3 * lo), hi + pad, points)
    return g[::-1] if m.direction == "down" else g


def _mag_phase(ph: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, S, H) phasors at force phasors F (n,) -> magnitude per newton and phase (deg)
    relative to the force, both (S, H, n)."""
    h = np.arange(1, ph.shape[2] + 1)
    rel = ph * np.exp(-1j * np.outer(np.angle(F), h))[:, None, :] / np.abs(F)[:, None, None]
    return np.abs(rel).transpose(1, 2, 0), np.degrees(np.angle(rel)).transpose(1, 2, 0)


def checked_law(model: str, params: Mapping[str, float]) -> JointLaw:
    """The joint law ``model`` with ``params`` (``effect.param`` names, every one of the
    model's and no other), refused (InputError naming ``model`` or ``parameters``) if it
    is malformed or cannot act in a structure's joint."""
    try:
        law = JointLaw(model, params, field="law")
    except InputError as exc:
        raise InputError(exc.message, field="model" if exc.field == "law.model" else "parameters") from None
    check_structure_law(law, field="model")
    return law


def sweep_curve(m: FrfMeasurement, law: JointLaw, points: int = DEFAULT_POINTS,
                margin: float = DEFAULT_MARGIN) -> dict[str, Any]:
    """Measured steps and the dense model curve of one sweep (module docstring)."""
    pr, fs = m.predictor, m.frfset
    H = fs.harmonics
    f = grid(m, points, margin)
    order = np.argsort(fs.frequencies_hz)
    Fabs = np.interp(f, fs.frequencies_hz[order], np.abs(fs.force)[order])
    rows = pr.rows(fs.sensors)
    ph = response_at(pr.system_with(law), f, Fabs, harmonics=H, samples=pr.samples, tol=pr.tol,
                     skip_failed=True)                          # (n, H+1, outputs) displacement
    ph = ph[:, 1:, :][:, :, rows]                               # (n, H, S)
    hw = 2 * np.pi * np.outer(f, np.arange(1, H + 1))           # (n, H)
    model_ph = np.stack([convert(ph[i], hw[i], fs.quantity) for i in range(f.size)]).transpose(0, 2, 1)
    ref = np.nanmax(np.abs(model_ph[:, :, :1]), axis=0, initial=0.0)     # (S, 1) harmonic 1's peak
    model_ph = np.where(np.abs(model_ph) <= ROUNDOFF * ref, 0.0, model_ph)
    mag, phase = _mag_phase(model_ph, Fabs.astype(complex))
    phase[mag == 0] = np.nan                                     # no response: no phase
    mmag, mphase = _mag_phase(fs.response, fs.force)
    failed = ~np.all(np.isfinite(model_ph), axis=(1, 2))
    return {"run": m.name, "level_n": m.level_n, "direction": m.direction, "mode": m.mode + 1,
            "quantity": fs.quantity, "units": UNITS[fs.quantity], "sensors": list(fs.sensors),
            "harmonics": H,
            "measured": {"frequency_hz": fs.frequencies_hz.tolist(), "magnitude_per_n": mmag.tolist(),
                         "phase_deg": mphase.tolist(),
                         "std_per_n": (fs.response_std / np.abs(fs.force)[:, None, None])
                         .transpose(1, 2, 0).tolist()},
            "model": {"frequency_hz": f.tolist(), "force_n": Fabs.tolist(), "magnitude_per_n": mag.tolist(),
                      "phase_deg": phase.tolist(), "points": int(np.count_nonzero(~failed)),
                      "not_converged_hz": f[failed].tolist()}}


def dense_curves(items: Sequence[Any], model: str, params: Mapping[str, float],
                 options: Mapping[str, Any] | None = None, points: int = DEFAULT_POINTS,
                 margin: float = DEFAULT_MARGIN) -> dict[str, Any]:
    """Per sweep of the FRF sets ``items`` (compared inside ``options['structure']``, with
    its ``modes`` and ``harmonics`` as :func:`labjoint.compare.frf_api.load_frf`): the
    measured steps and the model ``model`` with ``params`` evaluated densely (module
    docstring). JSON-ready (NaN as null)."""
    if isinstance(points, bool) or not isinstance(points, int) or not MIN_POINTS <= points <= MAX_POINTS:
        raise InputError(f"must be a whole number in [{MIN_POINTS}, {MAX_POINTS}], got {points!r}",
                         field="points")
    if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not 0 <= margin <= 2:
        raise InputError(f"must be a number in [0, 2], got {margin!r}", field="margin")
    law = checked_law(model, params)
    ms, _ = load_frf(list(items), None, dict(options or {}))
    sweeps = [sweep_curve(m, law, points, float(margin)) for m in ms]
    pr = ms[0].predictor
    return clean({"model": law.model.expr, "parameters": dict(law.params), "points": points, "margin": margin,
                  "harmonic_balance": {"harmonics": max(s["harmonics"] for s in sweeps),
                                       "samples_per_period": pr.samples, "tolerance": pr.tol,
                                       "reduction": {"method": "craig_bampton", "modes": pr.modes}
                                       if pr.modes is not None else {"method": "none"}},
                  "sweeps": sweeps})
