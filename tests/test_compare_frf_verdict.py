"""Issue 32 item 4: a candidate that lowers the error a lot but fails a weak test on coarse
data gets "inconclusive: sample the resonance more densely (<= x Hz steps)", or "the
validation set is too small", never "not among those tried"."""

from dataclasses import replace

import numpy as np
import pytest

from frfdata import hidden_law, predictor
from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared
from labjoint.compare.kinds.frf import prepare_frfsets
from labjoint.compare.kinds.frf_maps import FRF
from labjoint.compare.kinds.frf_verdict import sampling
from labjoint.structure.predict import synthetic_frfset


@pytest.fixture(scope="module")
def pr():
    return predictor()


def measurements(pr, offsets_hz):
    f0 = pr.natural_frequencies(1)[0]
    fs = synthetic_frfset(pr, hidden_law(), f0 + np.asarray(offsets_hz), [2.0, 5.0, 10.0],
                          ("free_end",), harmonics=1, noise=0.02, floor=1e-4, seed=4)
    return prepare_frfsets([("s", fs)], pr)


def weak_candidate(ms):
    """A real candidate of a real diagnosis, as a weak test would have judged it."""
    dg = diagnose_prepared(ms, "linear_stiffness", settings=DiagnoseSettings(candidates=("viscous",)))
    c = dg.candidates[0]
    assert c.nrmse_after_validation < 0.5 * dg.evaluation.nrmse(dg.validation_runs)
    return replace(c, significant=False, reason="p = 0.1 over 3 validation steps"), dg


def test_coarse_steps_ask_for_denser_sampling(pr):
    ms = measurements(pr, [-1.5, -0.3, 0.9])
    c, dg = weak_candidate(ms)
    fit, val, _ = FRF.split(ms)
    # modal damping 0.5 %: half-power band 2 x 0.005 x 40.1 Hz = 0.40 Hz, a quarter of it 0.10 Hz
    f_pk, df, rec = sampling(ms[0])
    assert df == pytest.approx(1.2) and rec == pytest.approx(2 * 0.005 * f_pk / 4)
    v = FRF.inconclusive([c], dg.evaluation.nrmse(dg.validation_runs), fit, val)
    assert v.startswith("inconclusive: viscous lowers the validation NRMSE")
    assert f"more densely (<= {rec:.2g} Hz steps)" in v and "not among" not in v


def test_dense_steps_but_a_tiny_validation_set_say_so(pr):
    ms = measurements(pr, np.linspace(-0.3, 0.3, 13))
    c, dg = weak_candidate(ms)
    fit, val, _ = FRF.split(ms)
    assert sampling(ms[0])[1] <= sampling(ms[0])[2] * 1.0001
    v = FRF.inconclusive([replace(c, test=replace(c.test, n=5))], dg.evaluation.nrmse(dg.validation_runs), fit, val)
    assert v.startswith("inconclusive") and "validation set is too small" in v
    # a strong candidate or a small gain is left to the usual verdicts
    assert FRF.inconclusive([replace(c, significant=True)], 1.0, fit, val) is None
