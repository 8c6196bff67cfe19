"""The phase-resonance plan with no hardware: exact messages, the loop's stability
(gain against the mode's phase slope) and its refusals, against a single mode written
here (its receptance in closed form)."""

import math

import numpy as np
import pytest

from labjoint.acquisition.messages import (Checkpoint, Configure, Measure, Measurement, Output, Ramp,
                                           Record, WaitSteady)
from labjoint.acquisition.plans import PLANS, dry_run, load_plan
from labjoint.acquisition.plans_resonance import LockFailed, loop_factor, phase_resonance
from labjoint.errors import InputError

FR, ZETA = 30.0, 0.01
STEADY = dict(steady_max_cycles=50, steady_tol=0.05, steady_window=4, measure_cycles=10, n_cycles=20)


class Mode:
    """A single mode at force amplitude 1 N per Vpp: acceleration and force phasors at the
    frequency last configured; a softening backbone fr(level) if asked."""

    def __init__(self, fr=FR, zeta=ZETA, soften=0.0, gain=1.0):
        self.fr, self.zeta, self.soften, self.gain = fr, zeta, soften, gain
        self.f, self.vpp, self.frequencies = None, None, []

    def __call__(self, msg):
        if isinstance(msg, Configure):
            self.f, self.vpp = msg.frequency_hz, msg.amplitude_vpp
            self.frequencies.append(self.f)
        if isinstance(msg, Ramp):
            self.vpp = msg.to_vpp
        if isinstance(msg, Measure):
            fr = self.fr * (1 - self.soften * self.vpp)
            w, wr = 2 * np.pi * self.f, 2 * np.pi * fr
            X = self.gain * self.vpp / (wr ** 2 - w ** 2 + 2j * self.zeta * wr * w)    # displacement
            A = -w * w * X
            return Measurement(self.f, {"acc": abs(A), "force": self.vpp}, {"acc": float(np.angle(A)), "force": 0.0},
                               "force")
        return None


def test_messages_exact_when_already_at_resonance():
    mode = Mode()
    msgs = dry_run(phase_resonance([1.0, 2.0], FR, (20.0, 40.0), response_channel="acc", **STEADY), mode)
    W = WaitSteady(max_cycles=50, tol=0.05, window=4)
    # a second measurement agreeing with the first: steady
    assert [type(m) for m in msgs] == [Configure, Output, WaitSteady, Measure, Measure, Checkpoint, WaitSteady,
                                       Record, Ramp, WaitSteady, Measure, Measure, Checkpoint, WaitSteady,
                                       Record, Output]
    assert msgs[:5] == [Configure(FR, 1.0), Output(True), W, Measure(10), Measure(10)]
    rec = msgs[7]
    assert rec.name == "phase_resonance_00_1Vpp" and rec.n_cycles == 20
    assert rec.metadata["plan"] == "phase_resonance" and rec.metadata["locked"] is True
    assert abs(rec.metadata["phase_error_deg"]) < 1e-6
    assert msgs[8] == Ramp(2.0) and msgs[-1] == Output(False)
    assert "level 1/2 (1 Vpp): 30 Hz" in msgs[5].label


@pytest.mark.parametrize("start", [27.0, 33.5])
def test_loop_locks_on_a_softening_backbone_from_either_side(start):
    mode = Mode(soften=0.01)
    msgs = dry_run(phase_resonance([1.0, 3.0, 9.0], start, (20.0, 40.0), response_channel="acc",
                                   phase_tol_deg=0.1, **STEADY), mode)
    recs = [m for m in msgs if isinstance(m, Record)]
    assert len(recs) == 3
    # the frequency each level locked at is that level's resonance (phase error <= 0.1 deg)
    locked = [m.metadata for m in recs]
    fr = [FR * (1 - 0.01 * v) for v in (1.0, 3.0, 9.0)]
    lock_f = []
    for i, r in enumerate(recs):
        cps = [m for m in msgs[:msgs.index(r)] if isinstance(m, Checkpoint) and m.data["level"] == i]
        lock_f.append(cps[-1].data["frequency_hz"])
        assert abs(locked[i]["phase_error_deg"]) <= 0.1
    assert lock_f == pytest.approx(fr, abs=0.1 / 180 * np.pi * ZETA * 30)   # e / S
    # the adapted slope is the mode's 1 / (zeta f_r) rad/Hz (within the secant's error)
    assert locked[-1]["phase_slope_rad_per_hz"] == pytest.approx(1 / (ZETA * fr[-1]), rel=0.1)
    # the loop's own (f, e) pairs are recorded, the last at the lock
    for i, md in enumerate(locked):
        assert len(md["phase_history"]) == md["iterations"] + 1
        assert md["phase_history"][-1][0] == pytest.approx(lock_f[i], abs=1e-12)
        assert np.degrees(md["phase_history"][-1][1]) == pytest.approx(md["phase_error_deg"], abs=1e-9)


def test_the_slopes_standard_error_is_the_least_squares_one():
    from scipy.stats import linregress

    from labjoint.identify.backbone import slope_sd

    rng = np.random.default_rng(5)
    f = np.linspace(29.1, 29.3, 6)                 # |e| < 45 deg
    e = np.arctan(-8.0 * (f - 29.2) + 0.01 * rng.standard_normal(f.size))
    hist = [[float(a), float(b)] for a, b in zip(f, e)] + [[28.0, 1.2]]       # beyond 45 deg: left out
    assert slope_sd(hist) == pytest.approx(linregress(f, np.tan(e)).stderr, rel=1e-9)
    assert np.isnan(slope_sd(hist[:2])) and np.isnan(slope_sd(None))


def test_stability_is_the_loop_factor_one_minus_gain_times_slope_ratio():
    S = 1 / (ZETA * FR)
    assert loop_factor(0.5, S, S) == 0.5
    for gain, guess, converges, alternates in ((0.5, ZETA, True, False), (1.5, ZETA, True, True),
                                               (0.5, ZETA * 5, False, True)):
        # without adaptation the estimate stays 1 / (guess f): factor 1 - g guess / zeta
        factor = loop_factor(gain, S, 1 / (guess * 30.2))
        mode = Mode()
        plan = phase_resonance([1.0], 30.2, (20.0, 40.0), response_channel="acc", gain=gain,
                               damping_guess=guess, adapt_slope=False, phase_tol_deg=0.01,
                               max_iterations=25, max_step_fraction=0.5, **STEADY)
        if converges:
            msgs = dry_run(plan, mode)
            e = np.array([m.data["phase_error_deg"] for m in msgs if isinstance(m, Checkpoint)])
            assert abs(factor) < 1 and abs(e[-1]) <= 0.01
            assert bool(np.all(np.sign(e[1:-1]) != np.sign(e[:-2]))) == alternates
            # near lock the error falls by the loop factor per update
            assert e[3] / e[2] == pytest.approx(factor, abs=0.05)
        else:
            assert factor < -1
            with pytest.raises(LockFailed, match="no lock within 25 updates|no resonance in the band"):
                dry_run(plan, mode)


def test_cannot_lock_stops_and_says_why():
    # no resonance in the band: the loop runs to its edge
    with pytest.raises(LockFailed, match="no resonance in the band 20-25 Hz.*band around the mode"):
        dry_run(phase_resonance([1.0], 22.0, (20.0, 25.0), response_channel="acc", **STEADY), Mode())
    # too little response
    with pytest.raises(LockFailed, match="too little response.*a higher level"):
        dry_run(phase_resonance([1.0], 29.0, (20.0, 40.0), response_channel="acc", min_response=1e3,
                                **STEADY), Mode())


def test_parameters_checked_and_registered():
    assert PLANS["phase_resonance"] is phase_resonance
    with pytest.raises(InputError) as e:
        phase_resonance([2.0, 1.0], 30.0, (20.0, 40.0), response_channel="acc")
    assert e.value.field == "levels_vpp"
    with pytest.raises(InputError) as e:
        phase_resonance([1.0], 50.0, (20.0, 40.0), response_channel="acc")
    assert e.value.field == "f_start_hz"
    with pytest.raises(InputError) as e:
        phase_resonance([1.0], 30.0, (20.0, 40.0), response_channel="acc", gain=2.5)
    assert e.value.field == "gain"
    plan = load_plan({"plan": "phase_resonance", "levels_vpp": [1.0], "f_start_hz": 30.0,
                      "band_hz": [20.0, 40.0], "response_channel": "acc"})
    assert isinstance(next(plan), Configure)
    assert math.isclose(loop_factor(1.0, 2.0, 1.0), -1.0)


class SlowMode(Mode):
    """The same mode, whose phase after a frequency change approaches its steady value by
    a factor 0.3 per measurement (a lightly damped mode's transient)."""

    def __init__(self, **kw):
        super().__init__(**kw)
        self.seen = None

    def __call__(self, msg):
        out = super().__call__(msg)
        if isinstance(msg, Measure):
            steady = out.phase_rad["acc"]
            self.seen = steady if self.seen is None else steady + 0.3 * (self.seen - steady)
            return Measurement(out.frequency_hz, out.amplitude, {"acc": self.seen, "force": 0.0}, "force")
        return out


def test_the_loop_waits_for_its_own_phase_to_settle():
    mode = SlowMode()
    msgs = dry_run(phase_resonance([1.0], 29.6, (20.0, 40.0), response_channel="acc", phase_tol_deg=0.05,
                                   **STEADY), mode)
    rec = next(m for m in msgs if isinstance(m, Record))
    # read in the transient, the slope would be 0.3-0.7 of the mode's; settled, it is the mode's
    assert rec.metadata["phase_slope_rad_per_hz"] == pytest.approx(1 / (ZETA * FR), rel=0.05)
    assert mode.frequencies[-1] == pytest.approx(FR, abs=0.05 / 180 * np.pi * ZETA * FR)
    counts = [sum(isinstance(m, Measure) for m in msgs[a:b])
              for a, b in zip([i for i, m in enumerate(msgs) if isinstance(m, Configure)],
                              [i for i, m in enumerate(msgs) if isinstance(m, Checkpoint)])]
    assert max(counts) > 2                              # more than one extra measurement was needed
    hasty = dry_run(phase_resonance([1.0], 29.6, (20.0, 40.0), response_channel="acc", phase_tol_deg=0.05,
                                    settle_measures=0, **STEADY), SlowMode())
    slope = next(m for m in hasty if isinstance(m, Record)).metadata["phase_slope_rad_per_hz"]
    assert slope < 0.85 / (ZETA * FR)                  # read in the transient: too flat
