"""User errors on the command line: one line naming the file, the good files still done,
a non-zero exit code; `hw check` fails when a configured instrument does not answer."""

import json

import numpy as np

from labjoint.cli.main import main
from labjoint.config import CONFIG_DIR


def _sine_csv(path, f=100.0, fs=10_000.0, n=20_000):
    t = np.arange(n) / fs
    y = 1e-6 * np.sin(2 * np.pi * f * t)
    F = 40.0 * np.sin(2 * np.pi * f * t + 0.2)
    rows = "\n".join(f"{a:.9g},{b:.9g},{c:.9g}" for a, b, c in zip(t, y, F))
    path.write_text(f"# frequency_hz: {f}\ntime_s,displacement_m,force_N\n{rows}\n")
    return path


def test_a_batch_reports_each_bad_file_and_still_analyses_the_good_ones(tmp_path, capsys):
    good = _sine_csv(tmp_path / "good.csv")
    (tmp_path / "junk.h5").write_text("not hdf5")
    code = main(["analyze", str(good), str(tmp_path / "missing.h5"), str(tmp_path / "junk.h5"),
                 "--json"])
    out, err = capsys.readouterr()
    res = json.loads(out)
    assert code == 2
    assert [r["run"] for r in res["runs"]] == ["good"]
    assert res["runs"][0]["stiffness_n_per_m"] > 0
    assert [e["file"] for e in res["errors"]] == [str(tmp_path / "missing.h5"),
                                                  str(tmp_path / "junk.h5")]
    assert "no such file" in res["errors"][0]["error"]
    lines = err.strip().splitlines()
    assert len(lines) == 2 and all(line.startswith("labjoint: error: ") for line in lines)
    assert "Traceback" not in err


def test_hw_check_exits_non_zero_when_the_configured_generator_does_not_answer(capsys):
    assert main(["hw", "check", "--json"]) == 0            # the simulated rig answers
    assert json.loads(capsys.readouterr().out)["ok"] is True
    assert main(["hw", "check", "--config", str(CONFIG_DIR / "rig-real.toml"), "--json"]) == 3
    res = json.loads(capsys.readouterr().out)
    assert res["ok"] is False and "generator" in res["problems"][0]


def test_messages_show_plain_numbers_not_numpy_reprs(tmp_path, capsys):
    bad = tmp_path / "back.csv"
    bad.write_text("time_s,displacement_m,force_N\n0,0,0\n0.002,0,0\n0.001,0,0\n")
    assert main(["analyze", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "time does not increase: 0.001 s after 0.002 s" in err and "np." not in err
