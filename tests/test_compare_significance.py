"""The stated significance test, its practical threshold, and tie reasons."""

import numpy as np
import pytest

from labjoint.compare.significance import (SignificanceSettings, correlation, is_significant,
                                           nrmse_se, paired_test)
from labjoint.compare.ties import tie_reason


def test_paired_test_detects_a_consistent_improvement_and_not_noise():
    rng = np.random.default_rng(0)
    base = 10.0 + rng.standard_normal(60)
    better = base - 0.5 + 0.1 * rng.standard_normal(60)
    same = base + 0.1 * rng.standard_normal(60)
    assert paired_test(base, better).p < 1e-10
    assert paired_test(base, same).p > 0.01
    assert paired_test(better, base).p > 0.99          # one-sided: worse is not better


def test_practical_threshold_rejects_a_real_but_negligible_improvement():
    s = SignificanceSettings()
    t = paired_test(np.full(50, 10.0) + np.linspace(0, 1e-3, 50), np.full(50, 9.999))
    assert t.p < 1e-6
    ok, why = is_significant(t, 0.0200, 0.0199, 0.0100, s)    # 1 % of the gap to the floor
    assert not ok and "practical threshold" in why
    ok, why = is_significant(t, 0.0200, 0.0120, 0.0100, s)    # 80 % of the gap
    assert ok and "p =" in why


def test_nrmse_se_converts_residual_energy_to_nrmse_units():
    t = paired_test(np.array([2.0, 2.2, 1.8, 2.1]), np.array([1.0, 1.1, 0.9, 1.0]))
    ssf = 100.0
    # N_a^2 - N_b^2 = sum dSSE / SSF: the se scales as 1 / (N_a + N_b)
    assert nrmse_se(t, 0.1, 0.2, ssf) == pytest.approx(t.se * t.n / (0.3 * ssf))


def test_correlation_counts_a_constant_added_force():
    assert correlation(np.ones(10), 2 * np.ones(10)) == pytest.approx(1.0)
    assert correlation(np.ones(10), np.zeros(10)) == 0.0


def test_tie_reason_states_numbers_and_physics():
    text = tie_reason("viscous", "channel_delay", 0.0101, 0.0103, 0.0008, 0.991)
    assert "1.01 %" in text and "99.1 %" in text and "k tau" in text and "several" in text
    text = tie_reason("coulomb", "iwan", 0.02, 0.021, 0.002, 0.97)
    assert "hysteretic" in text
