"""Runs for comparison: reading (HDF5, CSV), steady cycles, priming, fit/validation split."""

import numpy as np
import pytest

from labjoint.compare.runs import (default_split, prepare_run, prepare_runs, read_any,
                                   split_by_names)
from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.storage import import_csv
from test_compare_synth import FS, synth_run, sweep, write_csv


def test_csv_and_imported_run_file_read_alike(tmp_path):
    run = synth_run("c1", 400.0, 5e-6)
    write_csv(tmp_path / "c1.csv", run)
    a = read_any(tmp_path / "c1.csv")
    b = read_any(import_csv(tmp_path / "c1.csv", tmp_path / "data"))
    assert a.frequency_hz == b.frequency_hz == 400.0
    np.testing.assert_allclose(a.force, run.force, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(b.displacement, a.displacement)
    assert a.sample_rate_hz == pytest.approx(FS)


def test_bad_csv_names_the_file(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time_s,displacement_m\n0,0\n")
    with pytest.raises(InputError) as e:
        prepare_run(p)
    assert "bad.csv" in str(e.value)


def test_steady_cycles_are_whole_cycles_from_upward_centre_crossings():
    r = prepare_run(synth_run("a", 400.0, 5e-6, noise_f=0.0, phi0=1.0))
    per = FS / 400.0
    lengths = np.diff(r.cycles, axis=1).ravel()
    assert np.all(np.abs(lengths - per) <= 1)
    ph = r.phase()
    u = r.data.inputs.u
    # at phase 0 the displacement crosses its centre going up, at 0.25 it peaks
    near0 = np.abs(ph - 0.0) < 0.02
    near_peak = np.abs(ph - 0.25) < 0.02
    assert np.all(np.abs(u[near0]) < 0.15 * 5e-6)
    assert np.all(u[near_peak] > 0.95 * 5e-6)


def test_ramped_priming_puts_a_hysteretic_model_in_its_centred_steady_loop():
    """A record starting mid-cycle, primed, gives the same model force as a long history
    started from rest at the loop centre; without priming the loop starts off centre."""
    f, U = 400.0, 6e-6
    model = Model.parse("iwan")
    p = {"iwan.F_S": 150.0, "iwan.K_T": 1e7, "iwan.chi": -0.5, "iwan.beta": 0.3}
    long = synth_run("long", f, U, noise_f=0.0, phi0=0.0, cycles=40)
    F_long = model.eval(p, prepare_run(long, prime_cycles=0).data)
    start = int(round(17.37 * FS / f))          # cut mid-cycle
    cut = synth_run("cut", f, U, noise_f=0.0, phi0=0.0, cycles=40)
    cut.time, cut.displacement, cut.force = (cut.time[start:], cut.displacement[start:],
                                             cut.force[start:])
    pr = prepare_run(cut, prime_cycles="auto")
    assert pr.primed > 0
    F_cut = model.eval(p, pr.data)
    ref = F_long[start + pr.offset:start + pr.offset + F_cut.size]
    m = pr.steady
    assert np.max(np.abs(F_cut[m] - ref[m])) < 1e-4 * 60.0
    raw = prepare_run(cut, prime_cycles=0)
    F_raw = model.eval(p, raw.data)
    assert abs(np.mean(F_raw[raw.steady])) > 0.02 * 60.0   # relaxed off centre: shifted loop


def test_default_split_holds_out_the_highest_frequency():
    runs = prepare_runs(sweep(freqs=(200.0, 400.0, 800.0), amps=(2e-6, 5e-6), cycles=12))
    fit, val, rule = default_split(runs)
    assert {r.frequency_hz for r in val} == {800.0}
    assert {r.frequency_hz for r in fit} == {200.0, 400.0}
    assert "800" in rule


def test_default_split_with_one_frequency_keeps_both_amplitude_ends_in_the_fit():
    runs = prepare_runs(sweep(freqs=(400.0,), amps=(1e-6, 2e-6, 4e-6, 8e-6, 16e-6), cycles=12))
    fit, val, _ = default_split(runs)
    amps = sorted(r.amplitude_m for r in runs)
    assert min(r.amplitude_m for r in fit) == amps[0]
    assert max(r.amplitude_m for r in fit) == amps[-1]
    assert 1 <= len(val) < len(runs)


def test_split_by_names_errors_name_the_field():
    runs = prepare_runs(sweep(freqs=(400.0,), amps=(2e-6, 5e-6), cycles=12))
    with pytest.raises(InputError) as e:
        split_by_names(runs, ["nope"])
    assert e.value.field == "validate"
    with pytest.raises(InputError):
        split_by_names(runs, [r.name for r in runs])


def test_a_displacement_sensor_offset_changes_nothing():
    """A DC-coupled capacitive sensor reads its gap too: 40 um of offset must not move the
    fit of a stiffening spring (k u + k3 u^3 is not shift-invariant)."""
    from labjoint.models import ModelFitter
    from labjoint.storage import Run
    base = sweep(k3=4e15, amps=(3e-6, 6e-6, 1e-5))
    shifted = [Run(r.name, r.time, r.displacement + 40e-6, r.force, dict(r.metadata))
               for r in base]
    fits = []
    for runs in (base, shifted):
        prep = prepare_runs(runs)
        fits.append(ModelFitter("linear_stiffness+cubic_stiffness").fit([r.data for r in prep]))
    assert prepare_runs(shifted)[0].metadata["displacement_reference_m"] == pytest.approx(40e-6, abs=0.1e-6)
    a, b = fits
    assert b.params_["cubic_stiffness.k3"].value == pytest.approx(4e15, rel=0.03)
    assert b.nrmse_ == pytest.approx(a.nrmse_, rel=0.02)
