"""A ringdown recorded with the exciter attached (armature mass, suspension, coil damping on
the structure through the stinger), written here in closed form for one linear mode: the
force removal gives the structure's own mode, the amplitude is the recorded motion's, and
the apparent modal mass follows from a phase-resonance frequency alone
(labjoint.identify.backbone_mass)."""

import numpy as np
import pytest

from labjoint.identify.backbone_mass import mass_from_ringdown
from labjoint.signal.backbone import Backbone, BackbonePoint
from labjoint.signal.ringdown import ringdown_backbone

M, K, ZETA = 3.96, 3.96 * (2 * np.pi * 28.56) ** 2, 0.0042          # the structure's mode
MA, KA, CA = 0.3, 3.0e3, 13.0                                        # the exciter on it
FS = 5120.0


def attached_decay(x0=3e-4, seconds=3.0):
    """Free decay of (M + MA) x'' + (C + CA) x' + (K + KA) x = 0 from x0 at rest: the
    sensor's acceleration and the stinger force on the structure, -(MA x'' + CA x' + KA x)."""
    c = 2 * ZETA * np.sqrt(K * M)
    s = np.roots([M + MA, c + CA, K + KA])[0]
    s = complex(s.real, abs(s.imag))
    t = np.arange(int(seconds * FS)) / FS
    a_c = x0 / (1 - s / np.conj(s))                           # x(0) = x0, x'(0) = 0
    z = a_c * np.exp(s * t)
    x = 2 * z.real
    v = 2 * (s * z).real
    acc = 2 * (s * s * z).real
    return t, x, acc, -(MA * acc + CA * v + KA * x), s


def test_force_removal_gives_the_structures_mode_and_the_recorded_amplitude():
    t, x, acc, force, s = attached_decay()
    b = ringdown_backbone(acc, FS, quantity="acceleration", to_displacement=True, force=force, modal_mass_kg=M)
    fn = np.sqrt(K / M) / (2 * np.pi)
    for p in b.points:
        assert p.frequency_hz == pytest.approx(fn, rel=3e-5)
        assert p.damping_ratio == pytest.approx(ZETA, rel=0.01)
    # the amplitude is the displacement the sensor moved, at the recorded frequency |s|
    # (2.5 % below the structure's own): the same as without the force removal, the same
    # windows; at the structure's own frequency it would be (|s| / w_n)^2 = 0.95 of it
    raw = ringdown_backbone(acc, FS, quantity="acceleration", to_displacement=True)
    assert np.allclose(b.array("amplitude"), raw.array("amplitude"), rtol=1e-9)
    assert [p.frequency_hz for p in raw.points] == pytest.approx([abs(s) / (2 * np.pi)] * len(raw.points),
                                                                rel=1e-4)
    env = x[0] * np.exp(s.real * t)
    assert env.min() < raw.points[0].amplitude and raw.points[-1].amplitude < env.max()


@pytest.mark.parametrize("m0", [3.5, 4.3])
def test_the_modal_mass_where_the_corrected_ringdown_meets_the_phase_resonance_frequency(m0):
    t, x, acc, force, s = attached_decay()
    fn = np.sqrt(K / M) / (2 * np.pi)

    def ring(m):
        return ringdown_backbone(acc, FS, quantity="acceleration", to_displacement=True, force=force,
                                 modal_mass_kg=m).by_method()

    amps = [p.amplitude for p in ring(M)[0].points]
    level = Backbone([BackbonePoint(float(np.sqrt(min(amps) * max(amps))), fn, ZETA, "phase_resonance",
                                    1e-7, 1e-5, 1e-6)], "m", "displacement", "x")
    m, sd, note = mass_from_ringdown(level, ring, m0)
    assert m == pytest.approx(M, rel=1e-3) and 0 < sd < 0.01 * M
    assert f"{m0:.4g} kg" in note
    # a level outside the ringdown's amplitudes gives nothing to match
    far = Backbone([BackbonePoint(10 * max(amps), fn, ZETA, "phase_resonance", 1e-7, 1e-5, 1e-6)],
                   "m", "displacement", "x")
    assert mass_from_ringdown(far, ring, m0) is None
