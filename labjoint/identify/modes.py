"""Every mode in a band of measured FRFs, chosen without a GUI; half-power beside LSCF.

Per level (an FRF set's sweep or broadband record), over every response sensor at once:

1. LSCF poles (sdypy-ema, ``EMA.Model.get_poles("lscf")``) for model orders 2..2N on the
   band's lines (a non-uniform step-sine grid interpolated onto a uniform one first);
2. physical poles only: 0 < zeta < 0.2, inside the band;
3. stable poles: a pole with one at the previous order within 1 % in frequency and 30 %
   in damping (the stabilisation diagram's criterion);
4. the stable poles clustered in frequency (neighbours within 0.5 % or the line spacing,
   whichever is larger); a cluster is a mode when it holds a stable pole at no fewer
   than 30 % of the orders; its frequency and damping are the medians over the cluster;
5. LSFD modal constants of the chosen poles (sdypy-ema) give the mode shape at the
   sensors: the residues normalised to the largest, rotated to be real where the mode
   is real (the phase of the largest residue removed);
6. modes whose LSFD peak contribution is below 2 % of the band's largest FRF magnitude
   are left out (computational poles that stabilise on noise).

Half-power (seed 001: zeta = delta_f / (2 f_n)) on the strongest sensor's mobility in the
window between the neighbouring modes and within ten half-power widths of the LSCF pole, by :func:`labjoint.identify.modal.half_power`.

>>> f = np.arange(5.0, 60.0, 0.05)
>>> s, w = 2j * np.pi * f, 2 * np.pi * np.array([20.0, 40.0])
>>> h = sum(r / (s ** 2 + 2 * 0.01 * wn * s + wn ** 2) for r, wn in zip([1.0, 2.0], w))
>>> [round(m["frequency_hz"], 3) for m in find_modes(f, h[None, :] * s, "velocity", ["tip"])]
[20.0, 40.0]
"""

from __future__ import annotations

import contextlib
import io
import warnings
from typing import Any, Sequence

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.modal import FORMS, _from_zero, _grid, _mobility, half_power

MAX_ZETA = 0.2
STABLE_DF, STABLE_DZ = 0.01, 0.3
CLUSTER_DF = 0.005
MIN_SHARE = 0.3
MIN_CONTRIBUTION = 0.02


def find_modes(frequencies_hz: Any, frf: Any, quantity: str, sensors: Sequence[str],
               band: tuple[float, float] | None = None, order: int | None = None) -> list[dict[str, Any]]:
    """Modes (ascending) of FRFs shaped (sensors, lines) on one frequency axis (module doc)."""
    from sdypy import EMA

    f = np.asarray(frequencies_hz, float)
    h = np.atleast_2d(np.asarray(frf, complex))
    if band is not None:
        keep = (f >= band[0]) & (f <= band[1])
        f, h = f[keep], h[:, keep]
    if f.size < 12:
        raise InputError(f"the band {_band(band, f)} holds {f.size} frequency lines; "
                         "modes need at least 12", field="band")
    f, h = _grid(f, h)
    if quantity not in FORMS:
        raise InputError(f"must be one of {list(FORMS)}", field="quantity")
    df = float(f[1] - f[0])
    N = order or int(np.clip(f.size // 8, 12, 40))
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()), \
            np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        f0, h0 = _from_zero(f, h)
        m = EMA.Model(frf=h0, freq=f0, lower=f[0], upper=f[-1] + 0.5 * df, pol_order_high=N,
                      frf_form=FORMS[quantity][0])
        m.get_poles(method="lscf", show_progress=False)
        chosen = _clusters(m, f[0], f[-1], df)
        if not chosen:
            raise InputError(f"no mode in the band {_band(band, f)} (no pole stable over the "
                             "model orders)", field="band")
        m.pole_ind = np.array([[c["order"], c["index"]] for c in chosen])
        H_rec, A = m.get_constants(method="lsfd", f_lower=f[0], f_upper=f[-1])
    A = np.atleast_2d(np.asarray(A))
    poles = np.array([np.asarray(m.all_poles[c["order"]])[c["index"]] for c in chosen])
    mob = _mobility(f, h, quantity)
    peak = float(np.max(np.abs(mob)))
    w = 2j * np.pi * f
    out = []
    for r, c in enumerate(chosen):
        single = A[:, r, None] / (w - poles[r]) + np.conj(A[:, r, None]) / (w - np.conj(poles[r]))
        contrib = float(np.max(np.abs(w * single)))   # LSFD residues are receptance's
        if contrib < MIN_CONTRIBUTION * peak:
            continue
        shape = A[:, r]
        k = int(np.argmax(np.abs(shape)))
        shape = shape / shape[k]
        out.append({"frequency_hz": c["f"], "damping_ratio": c["z"], "orders_stable": c["orders"],
                    "frequency_spread_hz": c["f_iqr"], "damping_spread": c["z_iqr"],
                    "shape": {s: [float(v.real), float(v.imag)] for s, v in zip(sensors, shape)},
                    "reference_sensor": sensors[k]})
    if not out:
        raise InputError(f"no mode in the band {_band(band, f)} (the stable poles carry no response)",
                         field="band")
    edges = [f[0]] + [0.5 * (a["frequency_hz"] + b["frequency_hz"]) for a, b in zip(out, out[1:])] + [f[-1]]
    j = int(np.argmax(np.abs(mob).max(axis=1)))
    for mo, lo, hi in zip(out, edges, edges[1:]):
        # between the neighbouring modes, and within 10 half-power widths of this one
        reach = max(10 * mo["damping_ratio"] * mo["frequency_hz"], 3 * df)
        sel = (f >= max(lo, mo["frequency_hz"] - reach)) & (f <= min(hi, mo["frequency_hz"] + reach))
        fn, z = half_power(f[sel], h[j, sel], quantity) if sel.sum() >= 3 else (np.nan, np.nan)
        mo["half_power"] = {"frequency_hz": float(fn), "damping_ratio": float(z) if np.isfinite(z) else None,
                            "sensor": sensors[j]}
    return out


def _band(band: tuple[float, float] | None, f: np.ndarray) -> str:
    lo, hi = band if band is not None else ((f[0], f[-1]) if f.size else (np.nan, np.nan))
    return f"{lo:g}-{hi:g} Hz"


def _clusters(m: Any, lo: float, hi: float, df: float) -> list[dict[str, Any]]:
    """Stable physical poles clustered across orders (module docstring, steps 2-4)."""
    prev: tuple[np.ndarray, np.ndarray] | None = None
    stable = []   # (f, zeta, order index, pole index)
    for i, (fr, zr) in enumerate(zip(m.pole_freq, m.pole_xi)):
        fr, zr = np.asarray(fr, float), np.asarray(zr, float)
        poles = np.asarray(m.all_poles[i])
        ok = np.isfinite(fr) & (zr > 0) & (zr < MAX_ZETA) & (fr >= lo) & (fr <= hi) & (poles.imag > 0)
        cur = (fr[ok], zr[ok])
        if prev is not None and prev[0].size:
            for fk, zk, k in zip(cur[0], cur[1], np.flatnonzero(ok)):
                j = int(np.argmin(np.abs(prev[0] - fk)))
                if abs(prev[0][j] - fk) < STABLE_DF * fk and abs(prev[1][j] - zk) < STABLE_DZ * zk:
                    stable.append((float(fk), float(zk), i, int(k)))
        prev = cur
    if not stable:
        return []
    stable.sort()
    n_orders = len(m.pole_freq)
    groups, cur_g = [], [stable[0]]
    for p in stable[1:]:
        if p[0] - cur_g[-1][0] <= max(CLUSTER_DF * p[0], df):
            cur_g.append(p)
        else:
            groups.append(cur_g)
            cur_g = [p]
    groups.append(cur_g)
    chosen = []
    for g in groups:
        orders = {p[2] for p in g}
        if len(orders) < max(3, MIN_SHARE * n_orders):
            continue
        fs_, zs = np.array([p[0] for p in g]), np.array([p[1] for p in g])
        fm, zm = float(np.median(fs_)), float(np.median(zs))
        best = g[int(np.argmin(np.abs(fs_ - fm) / fm + np.abs(zs - zm) / zm))]
        q = lambda a: float(np.subtract(*np.percentile(a, [75, 25])))  # noqa: E731
        chosen.append({"f": fm, "z": zm, "order": best[2], "index": best[3], "orders": len(orders),
                       "f_iqr": q(fs_), "z_iqr": q(zs)})
    return chosen
