"""Flags for a user's likely mistakes in what was measured (issue 29 item 7), for the fit,
diagnose and ladder JSON (``measurement_flags``) and text.

- **negative measured energy loss**: a passive joint dissipates, so the measured loop's
  energy loss W (seed 002 Eq. 1; for a record, the sum of F v / fs over the judged
  samples) is positive. W < 0 beyond its uncertainty (a record: beyond 1 % of the sum
  of |F v| / fs, its stored energy's scale) means the loop runs backwards: a
  force (or displacement) sensor of inverted sign, or a voltage taken as the force.

- **complex measured modes** (the modal kind): a mode whose measured shape has a sensor
  more than ``COMPLEX_DEG`` from 0 or 180 deg (non-proportional damping: a shaker's
  back-EMF or a damper at one point, strong coupling through the drive). Real modes
  cannot carry it (a linear structure would be left above its floor, "structure
  remains"), so the modal model then fits a quadrature participation per mode and sensor
  (``modal.h<j>.<s>``, nlmode eq. 3b); with the joint between two points (nlmode_pair)
  every sensor reads the modes' measured imaginary parts on their quadrature (its eq. 7b)
  and the joint's relative displacement their real parts. The flag says which.

(A drive channel whose quantity is not the model's input, a voltage given to a
force-input model, is refused when the run is prepared,
:func:`labjoint.compare.kinds.check_quantities`; parameters whose standard error exceeds
their value carry a ``flag`` in the parameter table, :func:`labjoint.models.result.parameter_table`.)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from labjoint.identify.resolution import COVERAGE
from labjoint.structure.modal_basis import COMPLEX_DEG

NEGATIVE_ENERGY = ("measured energy loss {w:.4g} J < 0: the loop runs backwards (a passive joint "
                   "dissipates); usually a sensor of inverted sign, or a voltage taken as the force")


def measurement_flags(measurements: Sequence[Any]) -> list[dict[str, Any]]:
    """[{run, flag, message, ...}] for the measurements that show a likely mistake."""
    out: list[dict[str, Any]] = []
    bases: list[Any] = []
    for m in measurements:
        if getattr(m, "kind", None) == "modal" and not any(m.basis is b for b in bases):
            bases.append(m.basis)
            out.extend(complex_mode_flags(m.basis, pair=bool(getattr(m, "between", None))))
        if getattr(m, "kind", None) not in ("sine", "record"):
            continue
        loop = getattr(m, "loop", None)
        if loop is not None and getattr(loop, "summary", None):
            w = float(loop.summary.get("energy_loss_j", np.nan))
            unc = float(loop.summary.get("energy_loss_j_uncertainty", 0.0) or 0.0)
        else:
            w = float(m.figures(m.data.force)["energy_loss_measured_j"])
            j = m.judged                                  # the work's own scale: 1 % of sum |F v| / fs
            unc = 0.01 * float(np.sum(np.abs(m.data.force[j] * m.data.inputs.v[j]))) / m.fs / COVERAGE
        f = energy_flag(m.name, w, unc)
        if f:
            out.append(f)
    return out


def energy_flag(run: str, w: float, uncertainty: float) -> dict[str, Any] | None:
    """The negative-energy-loss flag of one loop (W, J, and its standard uncertainty), or None."""
    if np.isfinite(w) and w < -COVERAGE * (uncertainty if np.isfinite(uncertainty) else 0.0):
        return {"run": run, "flag": "negative_energy_loss", "energy_loss_j": float(w),
                "message": NEGATIVE_ENERGY.format(w=w)}
    return None


COMPLEX_MODE = ("mode {j} ({f:.4g} Hz) is complex: {s}'s phase is {a:.3g} deg from real (non-proportional "
                "damping, e.g. a shaker's back-EMF at one point); real modes cannot carry it, so ")
CARRIED = "every mode has a quadrature participation per sensor (modal.h<j>.<s>) beside its in-phase one"
CARRIED_PAIR = ("every sensor reads each mode's measured imaginary part on its quadrature (nlmode_pair eq. 7b); "
                "the joint's relative displacement takes the shapes' real parts")


def complex_mode_flags(basis: Any, pair: bool = False) -> list[dict[str, Any]]:
    """One flag per measured mode of ``basis`` further than COMPLEX_DEG from real; ``pair``:
    the joint acts between two points (whose sensors read the measured imaginary parts)."""
    tail = CARRIED_PAIR if pair else CARRIED
    return [{"flag": "complex_mode", "mode": j, "frequency_hz": m.frequency_hz, "sensor": m.phase_sensor,
             "phase_deg": m.phase_deg, "carried": True,
             "message": COMPLEX_MODE.format(j=j, f=m.frequency_hz, s=m.phase_sensor, a=m.phase_deg) + tail}
            for j, m in enumerate(basis.modes, start=1) if m.phase_deg > COMPLEX_DEG]
