"""A broadband record's FRFs as one level of an :class:`~labjoint.signal.frfset.FrfSet`.

Responses measured as different quantities (a vibrometer's velocity beside
accelerometers) are brought to the first response's quantity in the frequency domain,
exactly: H_q = H_p (i w)^(q - p), q and p the orders of displacement (0), velocity (1)
and acceleration (2). The drive is a force (N) or a voltage (V); the set says which and
its units, e.g. "m/s/V". The band where the drive carries power (its Welch density above
1 % of its largest) goes in the metadata, for ``labjoint modes``, and by default only
the lines in it are kept (outside it the FRF is noise over a silent drive).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.broadband import estimate
from labjoint.signal.frfset import DRIVES, QUANTITIES, FrfSet

ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}


def frfset_from_arrays(drive: Any, drive_quantity: str, responses: dict[str, tuple[str, Any]],
                       fs: float, *, level: float | None = None, run: str = "",
                       estimator: str = "H1", source: str = "record",
                       band: tuple[float, float] | str | None = "drive", **options: Any) -> FrfSet:
    """One level: FRFs of ``responses`` {name: (quantity, samples)} over ``drive``, on the
    lines of ``band``: (lo, hi) in Hz, "drive" (where the drive carries power) or None
    (every line with drive power above 1e-12 of its largest)."""
    if drive_quantity not in DRIVES:
        raise InputError(f"the drive must be a force or a voltage, got {drive_quantity!r}",
                         field="drive", file=source)
    if not responses:
        raise InputError("no response channel (displacement, velocity or acceleration)",
                         field="responses", file=source)
    for name, (q, _) in responses.items():
        if q not in QUANTITIES:
            raise InputError(f"channel {name!r} measures {q!r}, not one of {QUANTITIES}",
                             field=name, file=source)
    names = list(responses)
    target = responses[names[0]][0]
    y = np.vstack([np.asarray(responses[n][1], float) for n in names])
    r = estimate(drive, y, fs, estimator=estimator, **options)
    jw = 2j * np.pi * r.freq_hz
    conv = np.array([jw ** (ORDER[target] - ORDER[responses[n][0]]) for n in names])
    h, std, coh, lines = r.h * conv, r.std * np.abs(conv), r.coherence, r.freq_hz
    drive_band = _band(drive, fs, r.freq_hz)
    lo, hi = drive_band if band == "drive" else (band if band is not None else (0.0, np.inf))
    keep = (lines >= lo) & (lines <= hi)
    if keep.sum() < 2:
        raise InputError(f"the band {lo:g}-{hi:g} Hz holds {int(keep.sum())} FRF lines", field="band",
                         file=source)
    h, std, coh, lines = h[:, keep], std[:, keep], coh[:, keep], lines[keep]
    n = lines.size
    lv = float(level) if level else r.drive_rms
    md = {"method": r.method, "averages": r.averages, "drive_rms": r.drive_rms,
          "active_s": list(r.active_s), "band_hz": drive_band, "kind": "broadband",
          "converted": {nm: f"{responses[nm][0]} -> {target}" for nm in names
                        if responses[nm][0] != target}}
    return FrfSet(lines, np.full(n, lv), np.full(n, "up"), np.ones(n, complex), tuple(names),
                  h.T[:, :, None], std.T[:, :, None], target, None, tuple([run] * n) if run else (),
                  md, drive_quantity, estimator, coh.T)


def _band(drive: Any, fs: float, lines: np.ndarray) -> list[float]:
    """Lines where the drive's Welch density is above 1 % of its peak (first and last)."""
    from scipy.signal import welch
    u = np.asarray(drive, float)
    nper = int(min(u.size, 1 << int(np.log2(max(16, u.size // 8)))))
    f, p = welch(u - u.mean(), fs, nperseg=nper)
    ok = f[(p > 0.01 * p.max()) & (f > 0)]
    if not ok.size:
        return [float(lines[0]), float(lines[-1])]
    return [float(ok[0]), float(ok[-1])]
