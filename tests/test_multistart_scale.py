"""The modal kind's multi-start bounded solve (compare/kinds/multistart): a parameter whose
best start is 0 must still move (its unit is a tenth of its bounded range, not its own
zero): a first-order high-pass of corner f_c on a two-tone signal, fitted from f_c = 0,
recovers the corner of an independent closed-form response."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.compare.kinds.multistart import best_start_then_solve


def _highpass_tones(fc: float, gain: float, t: np.ndarray) -> np.ndarray:
    """Steady response of g s / (s + 2 pi fc) to cos(2 pi 1 t) + cos(2 pi 5 t) (closed form)."""
    out = np.zeros_like(t)
    for f in (1.0, 5.0):
        h = gain * 1j * f / (1j * f + fc)
        out += np.abs(h) * np.cos(2 * np.pi * f * t + np.angle(h))
    return out


@pytest.mark.parametrize("true_fc", [1.6, 0.4])
def test_a_parameter_started_at_zero_moves_to_its_value(true_fc):
    t = np.linspace(0, 4, 800, endpoint=False)
    y = _highpass_tones(true_fc, 2.0, t)
    names = ["gain", "fc"]
    bounds = {"gain": (0.0, np.inf), "fc": (0.0, 10.0)}
    x, sol, scale = best_start_then_solve(lambda z: _highpass_tones(z[1], z[0], t) - y, names, bounds,
                                          [np.array([1.0, 0.0])], 200, "diverged")
    assert scale[1] == pytest.approx(1.0)              # a tenth of (0, 10)
    assert x[1] == pytest.approx(true_fc, rel=1e-4)
    assert x[0] == pytest.approx(2.0, rel=1e-4)
