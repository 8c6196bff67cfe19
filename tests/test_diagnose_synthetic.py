"""diagnose on closed-form data: the missing effect first, the verdicts, ties, the JSON."""

import json

import numpy as np
import pytest

from labjoint.compare import diagnose_report, diagnose_runs, prepare_runs
from labjoint.errors import InputError
from test_compare_synth import sweep, synth_run

FEW = "viscous,cubic_stiffness,offset,inertia,channel_delay"


@pytest.fixture(scope="module")
def viscous_runs():
    return prepare_runs(sweep(k=1e7, c=150.0, noise_f=0.3, cycles=20))


def test_missing_viscous_ranks_first_and_brings_the_model_to_the_noise_floor(viscous_runs):
    d = diagnose_report(viscous_runs, "linear_stiffness", candidates=FEW, n_jobs=1)
    best = d.candidates[0]
    assert best.effect == "viscous" and best.significant
    assert best.nrmse_after <= 1.5 * d.noise.nrmse
    assert d.nrmse > 5 * d.noise.nrmse and not d.adequate
    assert best.fit.params_["viscous.c"].value == pytest.approx(150.0, rel=0.02)
    assert "quadrature" in best.evidence and "%" in best.evidence
    assert best.explanation.startswith("Rate-dependent loss")
    assert d.verdict.startswith("add viscous")
    # amplitudes in the words the page shows are written in µm, never "um"
    import re
    words = json.dumps(d.to_dict(), ensure_ascii=False)
    assert "µm" in words and not re.search(r"\d um\b", words)
    # judged on the held-out highest frequency, as the split rule says
    assert all("800Hz" in n for n in d.validation_runs)


def test_true_model_is_adequate_and_nothing_is_significant(viscous_runs):
    d = diagnose_report(viscous_runs, "linear_stiffness+viscous", candidates=FEW, n_jobs=1)
    assert d.adequate
    assert not any(c.significant for c in d.candidates)
    assert d.verdict.startswith("adequate")
    assert d.nrmse <= 1.5 * d.noise.nrmse


def test_structure_no_candidate_explains_is_said_so(viscous_runs):
    d = diagnose_report(viscous_runs, "linear_stiffness", candidates="offset,inertia", n_jobs=1)
    assert not d.adequate and d.best is None
    # only two of the registered candidates were tried: no claim about the others
    assert "not among the 2 tried (offset, inertia;" in d.verdict
    assert "no known effect" not in d.verdict


def test_no_known_effect_is_claimed_only_after_every_applicable_candidate():
    from labjoint.compare.candidates import candidate_effects
    from labjoint.compare.diagnosis import unexplained
    from labjoint.models import Model
    m = Model.parse("linear_stiffness+coulomb")
    every = candidate_effects(m)[0]
    assert "wear" in every                        # a modifier applies beside coulomb
    assert unexplained(m, every) == "structure remains that no known effect explains"
    some = unexplained(m, every[:-1])
    assert f"not among the {len(every) - 1} tried" in some and "1 registered effects not tried" in some


def test_delay_and_viscous_tie_at_one_frequency_and_separate_at_several():
    """F_measured(t) = k u(t + tau): at one frequency k tau du/dt, i.e. viscous c = k tau;
    the (omega tau)^2 stiffness change separates them across 200-1600 Hz."""
    k, tau = 1e7, 60e-6
    lead = dict(k=0.0, extra=lambda t, u, v: 0.0, noise_f=0.3, cycles=20)

    def runs(freqs):
        out = []
        for i, f in enumerate(freqs):
            for j, U in enumerate((3e-6, 8e-6)):
                r = synth_run(f"d{f:g}_{j}", f, U, seed=7 * i + j, phi0=0.3 + 2 * np.pi * f * tau,
                              **{**lead, "k": k})
                r.displacement = U * np.sin(2 * np.pi * f * r.time + 0.3)   # force leads by tau
                out.append(r)
        return prepare_runs(out)

    one = diagnose_report(runs((400.0,)), "linear_stiffness", candidates="viscous,channel_delay",
                          n_jobs=1)
    top = {c.effect for c in one.candidates[:2]}
    assert top == {"viscous", "channel_delay"}
    assert one.candidates[0].tie_with and "k tau" in one.candidates[0].tie_reason
    assert "tie" in one.to_dict()
    many = diagnose_report(runs((200.0, 800.0, 1600.0)), "linear_stiffness",
                           candidates="viscous,channel_delay", n_jobs=1)
    assert many.candidates[0].effect == "channel_delay" and not many.candidates[0].tie_with


def test_json_contract(viscous_runs):
    d = diagnose_runs(viscous_runs, "linear_stiffness", candidates="viscous,offset", n_jobs=1)
    json.dumps(d, allow_nan=False)
    assert set(d) >= {"model", "nrmse", "noise_floor", "adequate", "failures", "candidates"}
    assert all(set(f) >= {"where", "text"} for f in d["failures"])
    c = d["candidates"][0]
    assert set(c) >= {"effect", "nrmse_after", "significant", "evidence", "explanation"}
    assert [x["effect"] for x in d["candidates"]] == ["viscous", "offset"]


def test_bad_options_raise_input_errors(viscous_runs):
    with pytest.raises(InputError) as e:
        diagnose_runs(viscous_runs, "linear_stiffness", candidates="viscus")
    assert e.value.field == "candidates"
    with pytest.raises(InputError) as e:
        diagnose_runs(viscous_runs, "linear_stiffness", colour="red")
    assert e.value.field == "colour"
    with pytest.raises(InputError):
        diagnose_runs(viscous_runs, "linear_stifness")


def test_parallel_refits_give_the_serial_answer(viscous_runs):
    a = diagnose_report(viscous_runs, "linear_stiffness", candidates="viscous,offset,inertia",
                        n_jobs=1)
    b = diagnose_report(viscous_runs, "linear_stiffness", candidates="viscous,offset,inertia",
                        n_jobs=2)
    assert [c.effect for c in a.candidates] == [c.effect for c in b.candidates]
    for x, y in zip(a.candidates, b.candidates):
        assert x.nrmse_after == pytest.approx(y.nrmse_after, rel=1e-9)


def test_full_results_for_the_web_page_are_json(viscous_runs):
    from labjoint.compare import fit_runs

    d = diagnose_runs(viscous_runs, "linear_stiffness", candidates="viscous", n_jobs=1, full=True)
    f = fit_runs(viscous_runs, "linear_stiffness+viscous", full=True)
    json.dumps([d, f], allow_nan=False)
    assert set(d["maps"]) >= {"by_run", "by_phase", "by_quadrant", "reversal", "by_harmonic",
                              "over_time"}
    assert len(f["loops"]) == len(viscous_runs)
    assert set(f["curves"]) >= {"dissipation_vs_amplitude_slope", "stiffness_vs_amplitude_slope",
                                "dissipation_vs_frequency_exponent"}
