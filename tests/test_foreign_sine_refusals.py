"""Records the sine pipelines must refuse, with a message naming the problem, from an
independent generator written as another lab's CSV (design.md import format).

What a file can and cannot tell:
- detected: NaN/inf samples, a non-monotonic or jittered time column, wrong or missing
  unit headers, too few cycles, a swept sine or broadband record, a clipped channel
  (flat tops at its extreme), a force sensor of inverted sign (the loop runs backwards
  with negative stiffness), displacement and force swapped when the "displacement" then
  has an amplitude above 1 cm (a force of more than 0.01 N), a stated frequency 0.5 % or
  more off the cycles' own, a fundamental with fewer than 10 samples per period or within
  reach of the low-pass;
- not detected: millimetres written in a metre column (5 um as 0.005: a 5 mm amplitude is
  still a possible slip), displacement and force swapped with tiny forces, a clip at
  10 samples per cycle or just below a Coulomb slider's plateau (too few samples
  to tell from the plateau), a channel lag (W flagged below resolution, see
  test_loop_resolution).
"""

import json

import numpy as np
import pytest

from foreign_sine import Record, write_csv
from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.identify.analyze import analyze_arrays
from labjoint.signal.clipping import flat_top_fraction

BASE = Record(cycles=20)


def refusal(tmp_path, capsys, name, t, u, F, columns=("time_s", "displacement_m", "force_N"),
            meta=None, args=()):
    """stderr of a failing ``labjoint analyze --json`` on the CSV (nothing on stdout)."""
    path = write_csv(tmp_path / f"{name}.csv", t, u, F, meta, columns)
    code = main(["analyze", str(path), "--json", *args])
    out, err = capsys.readouterr()
    assert code != 0 and out == "" and "Traceback" not in err
    return err


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("channel", [1, 2])
def test_non_finite_samples_are_refused_by_line_and_column(tmp_path, capsys, bad, channel):
    arrays = list(BASE.arrays())
    arrays[channel][300] = bad
    err = refusal(tmp_path, capsys, "nonfinite", *arrays)
    assert "not a finite number" in err and ":302" in err
    assert ("displacement_m" if channel == 1 else "force_N") in err


@pytest.mark.parametrize("what, level", [("force", 0.8), ("displacement", 0.8),
                                         ("force", 0.95)])
def test_a_clipped_channel_is_refused(tmp_path, capsys, what, level):
    # before: a force clipped at 80 % gave W -11 %, a clipped displacement C +39 %
    t, u, F = BASE.arrays()
    if what == "force":
        F = np.clip(F, -level * np.abs(F).max(), level * np.abs(F).max())
    else:
        u = np.clip(u, -level * BASE.U, level * BASE.U)
    err = refusal(tmp_path, capsys, "clipped", t, u, F)
    assert f"'{what}'" in err and "clipped" in err and "input range" in err
    with pytest.raises(InputError, match="clipped") as exc:
        analyze_arrays(u, F, BASE.fs)
    assert exc.value.field == what


def test_quantisation_and_slider_plateaus_are_not_clipping():
    t, u, F = BASE.but(f=10.0, cycles=3).arrays()
    step = 5e-6 / 300                                    # a 16-bit input at 300 codes
    assert flat_top_fraction(np.rint(u / step) * step)[0] == 0.0
    j = BASE.but(joint="jenkins", k=2e7, f_s=20.0)
    t, u, F = j.arrays()
    assert flat_top_fraction(F, u)[0] == 0.0             # exact Coulomb plateaus
    assert flat_top_fraction(np.clip(F, -15, 15), u)[0] > 0.5


def test_swept_and_broadband_records_are_refused(tmp_path, capsys):
    fs = 25600.0
    t = np.arange(int(0.5 * fs)) / fs
    u = 5e-6 * np.sin(2 * np.pi * (50 * t + 200 * t ** 2))
    err = refusal(tmp_path, capsys, "sweep", t, u, 2e6 * u + 300 * np.gradient(u, t))
    assert "swept sine" in err and "not a steady sine" in err
    rng = np.random.default_rng(1)
    u = np.convolve(rng.normal(0, 1, t.size), np.ones(5) / 5, "same") * 5e-6
    err = refusal(tmp_path, capsys, "random", t, u, 2e6 * u + 300 * np.gradient(u, t))
    assert "broadband" in err and "not a steady sine" in err


def test_time_that_goes_back_or_jitters_is_refused(tmp_path, capsys):
    t, u, F = BASE.arrays()
    tb = t.copy()
    tb[300], tb[301] = tb[301], tb[300]
    err = refusal(tmp_path, capsys, "back", tb, u, F)
    assert "time does not increase" in err and "time_s" in err
    tj = t + np.random.default_rng(2).normal(0, 0.05 / BASE.fs, t.size)
    err = refusal(tmp_path, capsys, "jitter", tj, u, F)
    assert "irregular sampling" in err and "time_s" in err


def test_too_few_cycles_are_refused(tmp_path, capsys):
    err = refusal(tmp_path, capsys, "short", *BASE.but(cycles=2).arrays())
    assert "complete cycles" in err and "at least 3" in err


@pytest.mark.parametrize("header, expected", [
    ("time_s,displacement_mm,force_N", "wrong units header 'displacement_mm'"),
    ("time_s,displacement_m,force_kN", "wrong units header 'force_kN'"),
    ("time,displacement,force", "missing column 'time_s'"),
    ("time_s,disp_1_m,disp_2_m", "missing column 'displacement_m'")])
def test_missing_or_wrong_units_are_refused_by_column(tmp_path, capsys, header, expected):
    t, u, F = BASE.arrays()
    path = write_csv(tmp_path / "units.csv", t, u, F)
    lines = path.read_text().splitlines()
    path.write_text("\n".join([header] + lines[1:]) + "\n")
    assert main(["analyze", str(path), "--json"]) != 0
    out, err = capsys.readouterr()
    assert out == "" and expected in err


@pytest.mark.parametrize("joint", ["linear", "jenkins"])
def test_a_force_sensor_of_inverted_sign_is_refused(tmp_path, capsys, joint):
    # before: W, C and the stiffness all came out negative, as results
    r = BASE.but(joint=joint, k=2e7 if joint == "jenkins" else 2e6, noise_f=0.02)
    t, u, F = r.arrays()
    err = refusal(tmp_path, capsys, "inverted", t, u, -F)
    assert "'force'" in err and "inverted" in err and "backwards" in err
    err = refusal(tmp_path, capsys, "inverted_u", t, -u, F)    # or the displacement's
    assert "inverted" in err


def test_displacement_and_force_swapped_is_refused_when_the_amplitude_tells(tmp_path, capsys):
    # before: accepted with a 10 m displacement amplitude and W < 0
    t, u, F = BASE.arrays()
    err = refusal(tmp_path, capsys, "swapped", t, F, u)
    assert "'displacement'" in err and "swapped" in err and "metres" in err


def test_what_the_file_cannot_tell_is_documented_by_a_result(tmp_path, capsys):
    # millimetres in the metre column: analysed as a 5 mm joint (C and k scale by 1e-3)
    t, u, F = BASE.arrays()
    path = write_csv(tmp_path / "mm.csv", t, u * 1e3, F)
    assert main(["analyze", str(path), "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["runs"][0]
    assert row["displacement_amplitude_m"] == pytest.approx(5e-3, rel=1e-3)


@pytest.mark.parametrize("stated, refused", [(100.0, True), (101.0, True), (103.3, False)])
def test_a_stated_frequency_off_the_cycles_is_refused(tmp_path, capsys, stated, refused):
    # the cycles run at 103 Hz; before, 100 Hz in the metadata gave C +3 % silently
    r = BASE.but(f=103.0)
    path = write_csv(tmp_path / "freq.csv", *r.arrays(), {"frequency_hz": stated})
    code = main(["analyze", str(path), "--json"])
    out, err = capsys.readouterr()
    if refused:
        assert code != 0 and "'frequency_hz'" in err and "measured cycle frequency" in err
    else:                                                # within 0.5 %: C within 0.5 %
        row = json.loads(out)["runs"][0]
        assert row["damping_ns_per_m"] == pytest.approx(r.c, rel=5e-3)


@pytest.mark.parametrize("f, fs, field, words", [
    (1000.0, 6000.0, "frequency_hz", "samples per period"),    # before: W -2.8 %
    (2000.0, 51200.0, "cutoff_hz", "passes only"),             # before: W -3.2 %
    (2900.0, 100000.0, "cutoff_hz", "passes only")])           # before: W -66 %
def test_a_fundamental_the_loop_cannot_resolve_is_refused(f, fs, field, words):
    t, u, F = BASE.but(f=f, fs=fs).arrays()
    with pytest.raises(InputError, match=words) as exc:
        analyze_arrays(u, F, fs)
    assert exc.value.field == field
    # with the cutoff moved out of the way the 2 kHz loop is exact again
    if f == 2000.0:
        s = analyze_arrays(u, F, fs, cutoff_hz=None).summary
        assert s["energy_loss_j"] == pytest.approx(BASE.but(f=f).energy_loss, rel=2e-3)


def test_the_cli_moves_the_cutoff_for_a_fundamental_the_3_khz_filter_would_attenuate(
        tmp_path, capsys):
    r = BASE.but(f=2000.0, fs=51200.0, cycles=200)
    path = write_csv(tmp_path / "hi.csv", *r.arrays(), meta={"frequency_hz": 2000.0})
    assert main(["analyze", str(path), "--json"]) != 0
    assert "--cutoff" in capsys.readouterr().err             # the refusal names the option
    for cutoff in ("10000", "none"):
        assert main(["analyze", str(path), "--cutoff", cutoff, "--json"]) == 0
        row = json.loads(capsys.readouterr().out)["runs"][0]
        assert row["energy_loss_j"] == pytest.approx(r.energy_loss, rel=3e-3)
        assert row["damping_ns_per_m"] == pytest.approx(r.c, rel=3e-3)
    assert main(["analyze", str(path), "--cutoff", "5000", "--method", "stickslip",
                 "--friction", "0.3"]) != 0
    assert "--cutoff" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["analyze", str(path), "--cutoff", "-3"])
    assert "positive frequency" in capsys.readouterr().err
