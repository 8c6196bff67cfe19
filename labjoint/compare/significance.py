"""Is a candidate's improvement real, and can two candidates be told apart?

Test (stated): a one-sided paired t-test over the independent units of the validation
runs (the steady cycles of a sine; the periods or blocks of a record,
:mod:`labjoint.compare.measurement`). For each unit c the squared residual summed over
it is computed for the baseline (B_c) and the candidate (C_c); units are independent
(samples within one are not: the residual is correlated along the loop), and pairing
removes the unit-to-unit variation both models share. H0: mean(B_c - C_c) <= 0; t = mean / (sd /
sqrt(n)), p from Student's t with n - 1 degrees of freedom.

Few units (stated): with fewer than ``FEW_UNITS`` validation units (a short record split
in time holds 2-4 blocks) the t-test has almost no power: a candidate taking the
validation error from 35 % to the noise floor got p = 0.015 on 3 units. There the
improvement is also tested against the measurement noise itself (:func:`noise_test`): on
held-out samples with white noise e of variance sigma^2 (from the noise floor), the
difference of the two residual energies is a deterministic part plus 2 sum(e dF), dF the
change of the model force, whose standard deviation is 2 sigma ||dF||; z = dSSE /
(2 sigma ||dF||), one-sided normal p. The smaller of the two p values is taken and the
reason says which test decided. Data whose noise is known rather than estimated (residuals
whitened by stated uncertainties: a set with backbones, :mod:`labjoint.compare.kinds.combined`)
take the noise test whatever the number of units (``known``): there the units are far
from alike (a backbone band whose frequency misfit is hundreds of uncertainties beside
FRF phasors the candidate barely moves), which the t-test reads as noise.

Practical threshold (stated): a deterministic improvement repeats in every cycle, so even
a negligible one can reach a tiny p on many cycles; a candidate is significant only if
also its validation NRMSE improvement is at least ``practical`` (default 0.1) of the
baseline's gap to the validation noise floor, and at least ``min_rel`` (default 0.2) of
that noise floor (near the floor, a gain smaller than a fifth of the noise is within what
refitting an undetermined parameter can move by chance).

Tie (stated): two candidates are tied when the difference of their validation NRMSEs is
within its uncertainty, max(2 standard errors of the paired per-cycle test between them,
``tie_tol`` x the noise floor), and what they add to the baseline's prediction is
nearly the same on the data: correlation of the two changes of the model force above
``tie_corr`` (default 0.95). Where the noise is known (whitened data, above) the standard
error of that difference is the noise's, from 2 sigma ||F_a - F_b||
(:func:`labjoint.compare.ties.mark_ties`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class SignificanceSettings:
    alpha: float = 0.01
    practical: float = 0.1
    min_rel: float = 0.2
    tie_tol: float = 0.1
    tie_corr: float = 0.95

    def describe(self) -> str:
        return (f"one-sided paired t-test of per-cycle validation residual energy (cycles as "
                f"independent units; with fewer than {FEW_UNITS} units also a z-test of the residual-energy change against the measurement noise, the smaller p), p < {self.alpha:g}, and improvement >= "
                f"{self.practical:g} x the gap to the noise floor and >= {self.min_rel:g} x "
                f"the noise floor; ties: NRMSE difference within max(2 SE, {self.tie_tol:g} x "
                f"noise floor) and correlation of the added force > {self.tie_corr:g}")


FEW_UNITS = 8


@dataclass(frozen=True)
class PairedTest:
    """Result of the paired per-cycle test (``mean``: mean of B_c - C_c, N^2); ``method``:
    "paired t" or "noise" (:func:`noise_test` decided, the units being few)."""

    t: float
    p: float
    n: int
    mean: float
    se: float
    method: str = "paired t"


def paired_test(base: np.ndarray, cand: np.ndarray) -> PairedTest:
    """One-sided paired t-test that ``cand`` has less per-cycle residual energy than ``base``."""
    d = np.asarray(base, float) - np.asarray(cand, float)
    n = d.size
    if n < 2:
        return PairedTest(float("nan"), 1.0, n, float(d.mean()) if n else 0.0, float("inf"))
    mean = float(d.mean())
    sd = float(d.std(ddof=1))
    se = sd / np.sqrt(n)
    if se == 0.0:
        t = float("inf") if mean > 0 else float("-inf") if mean < 0 else 0.0
        p = 0.0 if mean > 0 else 1.0
    else:
        t = mean / se
        p = float(stats.t.sf(t, n - 1))
    return PairedTest(float(t), p, n, mean, float(se))


def noise_test(base: np.ndarray, cand: np.ndarray, dforce_sq: float, noise_var: float,
               known: bool = False) -> PairedTest:
    """The paired test over units (:func:`paired_test`), and with fewer than ``FEW_UNITS``
    units (or any number when the noise is ``known``) also the test against measurement
    noise (module docstring): the smaller p. ``dforce_sq``: sum over the validation
    samples of the squared change of the model force (N^2); ``noise_var``: the
    white-noise variance per sample (N^2)."""
    t = paired_test(base, cand)
    if (t.n >= FEW_UNITS and not known) or not (dforce_sq > 0 and noise_var > 0):
        return t
    d_sse = float(np.sum(base) - np.sum(cand))
    sd = 2.0 * float(np.sqrt(noise_var * dforce_sq))
    z = d_sse / sd
    p = float(stats.norm.sf(z))
    if not p < t.p:
        return t
    return PairedTest(z, p, t.n, t.mean, t.se, "noise")


def nrmse_se(test: PairedTest, nrmse_a: float, nrmse_b: float, ssf: float) -> float:
    """Standard error, in NRMSE units, of the difference of two pooled NRMSEs from the
    paired per-cycle test of their residual energies: N_a^2 - N_b^2 = dSSE / SSF, so
    N_a - N_b = dSSE / (SSF (N_a + N_b)), dSSE summed over the ``test.n`` cycles."""
    if nrmse_a + nrmse_b <= 0 or ssf <= 0 or not np.isfinite(test.se):
        return float("inf")
    return float(test.se * test.n / ((nrmse_a + nrmse_b) * ssf))


def is_significant(test: PairedTest, base_nrmse: float, cand_nrmse: float, floor: float,
                   s: SignificanceSettings) -> tuple[bool, str]:
    """Significant (module docstring) and the reason in words with the numbers."""
    gain = base_nrmse - cand_nrmse
    gap = base_nrmse - floor
    need = max(s.practical * max(gap, 0.0), s.min_rel * floor)
    if not test.p < s.alpha:
        return False, f"p = {test.p:.2g} >= {s.alpha:g}"
    if not gain >= need:
        return False, (f"p = {test.p:.2g}, but the improvement {100 * gain:.3g} % is below the "
                       f"practical threshold {100 * need:.3g} %")
    how = (f"over {test.n} validation cycles" if test.method == "paired t" else
           f"against the measurement noise ({'' if test.n < FEW_UNITS else 'stated; '}"
           f"{'only ' if test.n < FEW_UNITS else ''}{test.n} validation units)")
    return True, f"p = {test.p:.2g} {how}, improvement {100 * gain:.3g} %"


def correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Correlation (uncentred: a constant added force counts) of two changes of the model
    force (0 if either is zero)."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    na, nb = float(np.sqrt(a @ a)), float(np.sqrt(b @ b))
    if na == 0 or nb == 0:
        return 0.0
    return float(a @ b / (na * nb))
