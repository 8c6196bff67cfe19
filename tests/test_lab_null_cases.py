"""No invented effects: lab-like records of a joint the baseline fully explains.

Records from :mod:`labrecords` carry rest before and after, raised-cosine ramps, a DC
displacement offset, 50/60 Hz mains hum on the force, noise and 24-bit quantisation, all
at once. ``diagnose`` must call the baseline adequate, quickly (no candidate fitted when
the baseline is at the noise floor of the validation runs), and still find a hidden
effect of a few noise floors. Random null/effect rates: ``benchmarks/bench_null_cases.py``.
"""

import numpy as np
import pytest

from labjoint.compare import diagnose_report, prepare_run
from labjoint.signal.mains import remove_mains
from labrecords import FS, LabCase

BASELINE = "linear_stiffness+coulomb"


def test_mains_line_is_removed_and_a_ramped_drive_is_left_alone():
    rng = np.random.default_rng(3)
    t = np.arange(int(0.3 * FS)) / FS
    env = np.clip(t / 0.03, 0, 1) * np.clip((0.3 - t) / 0.03, 0, 1)
    drive = 80 * env * np.sin(2 * np.pi * 196.9 * t)        # skirt reaches 3 x 60 Hz
    hum = 1.2 * np.sin(2 * np.pi * 50.0 * t + 0.4)
    noise = rng.normal(0, 0.3, t.size)
    y, lines = remove_mains(drive + hum + noise, FS, 196.9)
    assert [round(x.frequency_hz) for x in lines] == [50]
    assert lines[0].amplitude == pytest.approx(1.2, rel=0.05)
    assert np.std(y - drive - noise) < 0.1 * np.std(hum)
    # nothing to remove: no line found, the record is returned unchanged
    y, lines = remove_mains(drive + noise, FS, 196.9)
    assert lines == [] and np.array_equal(y, drive + noise)


def test_rest_and_ramps_are_left_out_of_the_steady_cycles(tmp_path):
    case = LabCase.draw(101)
    path = case.write(tmp_path)[2]                          # 9 um
    p = prepare_run(path)
    amp = p.loop.displacement_amplitude[p.cycle_ids]
    assert np.median(amp) == pytest.approx(9e-6, rel=0.03)  # (half peak-to-peak, 3rd harm.)
    assert np.all(np.abs(amp / np.median(amp) - 1) < 0.01)  # only full-amplitude cycles
    assert amp.size >= 0.8 * case.cycles
    assert p.metadata["mains_removed"]["force"][0]["frequency_hz"] == pytest.approx(
        case.hum_hz, rel=0.01)
    assert p.metadata["displacement_reference_m"] == pytest.approx(case.gap_m, abs=0.05e-6)


@pytest.mark.parametrize("seed", [100, 102, 105])
def test_null_lab_records_are_adequate_without_fitting_candidates(tmp_path, seed):
    d = diagnose_report(LabCase.draw(seed).write(tmp_path), BASELINE)
    assert d.adequate, d.verdict
    assert d.candidates == [] and "no candidate fitted" in d.verdict
    # no candidate fitted: within half the significance test's min_rel (0.2) of the floor
    assert d.nrmse_validation <= 1.1 * d.noise_floor_validation


@pytest.mark.slow
@pytest.mark.parametrize("seed, effect", [(500, "viscous"), (501, "cubic_stiffness")])
def test_hidden_effect_in_lab_records_is_found(tmp_path, seed, effect):
    d = diagnose_report(LabCase.draw(seed, effect).write(tmp_path), BASELINE)
    assert not d.adequate
    assert d.best is not None and effect in {d.best.effect, *d.best.tie_with}, d.verdict
