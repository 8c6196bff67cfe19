"""The sensors' participations of the modal kind (nlmode eqs. 3, 3b): every response
channel is linear in them given mode 1's states and the linear modes' (``modal.phi1.<s>``,
``modal.g<j>.<s>``, the residual term ``modal.r.<s>`` and, for complex measured modes,
``modal.h<j>.<s>``), so :func:`project` solves them by linear least squares pooled over
the records at every trial of the fit (variable projection, :mod:`.modal_fit`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from labjoint.compare.kinds.modal import ModalMeasurement
from labjoint.structure.nlmode import QUANTITY_ORDER


def gain_names(m: ModalMeasurement) -> list[str]:
    out = []
    for ch in m.channels:
        if ch != m.basis.reference:
            out.append(f"modal.phi1.{ch}")
        out += [f"modal.g{j + 2}.{ch}" for j in range(len(m.lin))] + [f"modal.r.{ch}"] \
            + _quadrature_names(m, ch)
    return out


def _quadrature_names(m: ModalMeasurement, ch: str) -> list[str]:
    """Complex measured modes: every mode's quadrature participation at ``ch`` (nlmode eq.
    3b; none for mode 1 at the reference, which defines it), else none."""
    if not m.basis.complex:
        return []
    return ([] if ch == m.basis.reference else [f"modal.h1.{ch}"]) + \
        [f"modal.h{j + 2}.{ch}" for j in range(len(m.lin))]


def project(ms: Sequence[ModalMeasurement], qs: Sequence[np.ndarray],
            vals: Mapping[str, float] | None = None
            ) -> tuple[dict[str, float], dict[str, float], np.ndarray]:
    """Participations by linear least squares over the records (module docstring), their
    conditional standard errors, and the residual vector."""
    ref = ms[0].basis.reference
    gains: dict[str, float] = {}
    stderr: dict[str, float] = {}
    res = []
    quad: dict[tuple[int, str], list[np.ndarray]] = {}   # per record and quantity, computed once
    for ch in ms[0].channels:
        rows, target = [], []
        for rec, (m, q) in enumerate(zip(ms, qs)):
            i = m.channels.index(ch)
            j, s = m.judged, m.scales[i]
            d = QUANTITY_ORDER[m.quantities[i]]
            cols = [q[j, d]] + [p[j, d] for p in m.linear(vals or {}, q)] \
                + [m.residual_input(m.quantities[i], vals, q)[j]]
            if m.basis.complex:
                key = (rec, m.quantities[i])
                if key not in quad:
                    quad[key] = m.quadrature(m.quantities[i], vals or {}, q)
                cols += [c[j] for c in (quad[key] if ch != ref else quad[key][1:])]
            cols = [(c - c.mean()) / s for c in cols]
            n = j.stop - j.start
            y = m.data.force[m.channel_part(i)]
            if ch == ref:
                y = y - cols[0]
                cols = cols[1:]
            rows.append(np.column_stack(cols) if cols else np.zeros((n, 0)))
            target.append(y)
        A, y = np.vstack(rows), np.concatenate(target)
        names = ([] if ch == ref else [f"modal.phi1.{ch}"]) + \
            [f"modal.g{j + 2}.{ch}" for j in range(len(ms[0].lin))] + [f"modal.r.{ch}"] \
            + _quadrature_names(ms[0], ch)
        if A.shape[1]:
            coef, *_ = np.linalg.lstsq(A, y, rcond=None)
            r = y - A @ coef
            dof = max(1, y.size - A.shape[1])
            try:
                cov = np.linalg.inv(A.T @ A) * float(r @ r) / dof
                se = np.sqrt(np.clip(np.diag(cov), 0, None))
            except np.linalg.LinAlgError:
                se = np.full(A.shape[1], np.nan)
            for k, c, e in zip(names, coef, se):
                gains[k], stderr[k] = float(c), float(e)
        else:
            r = y
        res.append(r)
    return gains, stderr, np.concatenate(res)
