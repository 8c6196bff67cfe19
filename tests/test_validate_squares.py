"""validate.signal's overflow check (sum of squares finite) without a BLAS dot product:
the fast bound and the exact fallback agree with the sum of squares itself."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.signal import validate


@pytest.mark.parametrize("peak, n", [(1e140, 1000), (9e149, 10), (1e151, 100), (1e153, 3),
                                     (1.2e154, 1), (1e154, 4), (1e155, 1), (1e200, 5)])
def test_signal_refuses_exactly_the_records_whose_squares_overflow(peak, n):
    x = np.full(n, peak)
    x[::2] *= -1.0
    total = 0.0
    for _ in range(n):                   # Python floats: overflow gives inf, no warning
        total += float(peak) * float(peak)
    squares_finite = math.isfinite(total)
    if squares_finite:
        assert validate.signal(x, "x") is not None
    else:
        with pytest.raises(InputError, match="too large to square"):
            validate.signal(x, "x")


def test_signal_names_the_field_and_passes_ordinary_records():
    rng = np.random.default_rng(3)
    x = 1e-6 * rng.standard_normal((2, 5000))
    assert np.array_equal(validate.signal(x, "u", ndim=(2,)), x)
    x[1, 7] = 1e170
    with pytest.raises(InputError) as err:
        validate.signal(x, "u", ndim=(2,))
    assert err.value.field == "u"
