"""Parameter covariance of a least-squares fit from its Jacobian."""

from __future__ import annotations

import numpy as np


def covariance(J: np.ndarray, ssr: float) -> tuple[np.ndarray, str]:
    """s^2 (J^T J)^-1 via SVD of the column-scaled Jacobian; NaN (not a number: no
    standard error exists, never a small one) for the parameters along directions the
    data do not determine."""
    n, p = J.shape
    if p == 0:
        return np.zeros((0, 0)), ""
    norms = np.sqrt(np.sum(J * J, axis=0))
    norms[norms == 0] = 1.0
    _, s, vt = np.linalg.svd(J / norms, full_matrices=False)
    ok = s > 1e-10 * s[0]
    s2 = ssr / max(n - p, 1)
    cov = (vt[ok].T / s[ok] ** 2) @ vt[ok] * s2 / np.outer(norms, norms)
    note = ""
    if not ok.all():
        bad = np.any(np.abs(vt[~ok]) > 0.1, axis=0)
        cov[bad, :] = np.nan
        cov[:, bad] = np.nan
        note = "; Jacobian rank-deficient: some parameters are not determined by the data"
    return cov, note
