"""Shared backbone test data: a measured backbone of mode 1 of the FRF tests' structure
(tests/frfdata.py) with a hidden joint law, with stated noise, written as a backbone file."""

from __future__ import annotations

import numpy as np

from labjoint.signal.backbone import Backbone, BackbonePoint, save_backbones
from labjoint.structure.epmc import EPMC

F_SD, Z_SD = 2e-4, 0.02          # Hz; relative


def measured(pr, law, n=12, lo=2e-5, hi=2e-3, seed=1, method="phase_resonance") -> Backbone:
    """Mode 1's backbone of ``law`` in the predictor's structure at n amplitudes (m at
    free_end), frequency noise F_SD Hz and damping noise Z_SD relative, stated as the
    points' uncertainties."""
    rng = np.random.default_rng(seed)
    b, _ = EPMC(pr.system_with(law), 0, 3, 32, "free_end").backbone(np.geomspace(lo, hi, n))
    pts = [BackbonePoint(p.amplitude, p.frequency_hz + F_SD * rng.standard_normal(),
                         p.damping_ratio * (1 + Z_SD * rng.standard_normal()), method,
                         0.0, F_SD, Z_SD * p.damping_ratio) for p in b.points]
    return Backbone(pts, "m", "displacement", "free_end")


def write(path, *backbones: Backbone, mode: int = 1):
    return save_backbones(path, list(backbones), mode)
