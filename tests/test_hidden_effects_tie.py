"""A small channel delay and viscous damping: the same thing at one frequency, told apart
by data at several frequencies (simulated rig, delay hidden on the micro-slip joint).

At one frequency and small amplitude (the joint nearly linear) a force channel leading
by tau adds k tau du/dt, exactly what a dashpot c = k tau adds: ``diagnose`` must report
the two as a tie with the reason, and either is accepted. Over 150-800 Hz the delay's
second-order stiffness change -k (omega tau)^2 / 2 and its phase shift of the higher
harmonics separate them: channel_delay must win alone. About 60 s each (slow).
"""

import pytest

from labjoint.compare import diagnose_report
from test_hidden_effects_rig import acquire

BASELINE = "linear_stiffness+iwan"
DELAY = [{"name": "channel_delay", "tau": -40e-6}]


@pytest.mark.slow
def test_one_frequency_reports_a_tie_with_its_reason(tmp_path):
    paths = acquire(tmp_path, effects=DELAY, levels={300.0: [1.0, 1.5, 2.0, 2.5]}, from_rest=True,
                    cycles=50, seconds=0.25)
    d = diagnose_report(paths, BASELINE)
    best = d.candidates[0]
    assert {best.effect, *best.tie_with} >= {"viscous", "channel_delay"}
    assert "k tau" in best.tie_reason and "several" in best.tie_reason
    assert d.to_dict()["tie"]["effects"][0] in ("viscous", "channel_delay")


@pytest.mark.slow
def test_several_frequencies_separate_them(tmp_path):
    levels = {150.0: [2.0, 3.5, 5.0], 400.0: [4.0, 9.0, 15.0], 800.0: [8.0, 14.0, 20.0]}
    paths = acquire(tmp_path, effects=DELAY, levels=levels, from_rest=True, cycles=50, seconds=0.25)
    d = diagnose_report(paths, BASELINE)
    best = d.candidates[0]
    assert best.effect == "channel_delay" and "viscous" not in best.tie_with
    visc = next(c for c in d.candidates if c.effect == "viscous")
    assert visc.nrmse_after_validation > 2 * best.nrmse_after_validation
    assert best.fit.params_["channel_delay.tau"].value == pytest.approx(-40e-6, rel=0.05)
