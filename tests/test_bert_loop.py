"""The whole model loop on the real BERT beam through the CLI (issue 29 item 8; slow: about
10 min on a quiet machine, 28 min at load 13): ``benchmarks/bench_bert.py --json`` imports
the tests, takes the modes of the 0.25 V random test, runs ``labjoint ladder --modal`` on the
14 sines and the 0.25 V random test, fits and saves the ladder's model and the linear one,
and predicts the 0.30 V random test (never fitted) and the sines.

Asserted: what is met (an even effect named first, then an odd softening law; the
ladder's error falling at each step; the 0.30 V test's mode 1 within 0.05 Hz of Testlab's
18.69 Hz; the 2nd harmonic at 9.5 Hz within 30 %; the 0.30 V test in no fit). Not met, and
so not asserted (README, "The model loop on the BERT beam", says what is missing): the
ladder's error within 3x the noise floor, the 0.30 V NRMSE 2x below the linear model's,
the 3rd harmonic at 6-6.5 Hz within 30 %."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BERT = Path(os.environ.get("LABJOINT_BERT_DATA", "/work/shared/data/bert/bert.h5"))
EVEN = ("quadratic_stiffness", "bilinear_stiffness", "contact", "asymmetric_slip")
#: odd laws that soften, and the sign of the parameter that says so
ODD_SOFTENING = {"cubic_stiffness": -1.0, "saturating_stiffness": 1.0}
SOFTENING_PARAM = {"cubic_stiffness": "cubic_stiffness.k3", "saturating_stiffness": "saturating_stiffness.k_s"}


@pytest.mark.slow
@pytest.mark.skipif(not BERT.exists(), reason="the BERT data are not on this machine")
def test_bert_loop_names_even_then_odd_and_predicts_mode_1_and_h2(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_bert.py"), "--json",
                           "--data", str(BERT), "--work", str(tmp_path)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=5400)
    (tmp_path / "bench.out").write_text(proc.stdout + proc.stderr)      # kept for a reader
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = next(json.loads(line) for line in proc.stdout.splitlines() if line.startswith('{"named"'))
    named = res["named"]
    assert named[0] in EVEN, named
    # an odd softening after the even effect: the cubic (named on this data so far) or the
    # saturating law, which the ladder tries beside it
    assert set(named[1:]) & set(ODD_SOFTENING), named
    nr = [s["nrmse"] for s in res["ladder"]]
    assert all(b < a for a, b in zip(nr, nr[1:])), nr
    nv = [s["nrmse_validation"] for s in res["ladder"]]
    assert all(b < a for a, b in zip(nv, nv[1:])), nv
    assert res["mode1_peak_hz_predicted_0p30"] == pytest.approx(18.69, abs=0.05)
    h2 = res["harmonics"]["h2_9p5"]
    assert h2["model"] == pytest.approx(h2["measured"], rel=0.30)
    assert h2["measured"] == pytest.approx(0.70, abs=0.02)           # README: 0.68-0.70
    for tag in ("model", "linear"):
        fitted = json.loads((tmp_path / f"{tag}.json").read_text())["fit_runs"]
        assert fitted and not any("0p30" in r for r in fitted), fitted
    # the 0.30 V residual's parts: bands and burst/decay each add in quadrature to the NRMSE,
    # and mode 1's and mode 2's bands hold most of it (the diagnosis)
    for tag, parts in res["nrmse_0p30_parts"].items():
        total = res["nrmse_0p30"][tag]
        bands = (parts["mode1_12_30hz"], parts["mode2_80_115hz"], parts["elsewhere"])
        assert sum(b * b for b in bands) ** 0.5 == pytest.approx(total, rel=1e-6), (tag, parts)
        assert (parts["driven"] ** 2 + parts["free_decay"] ** 2) ** 0.5 == pytest.approx(total, rel=1e-6)
        assert parts["elsewhere"] < 0.3 * total, parts
        assert parts["drive_end_s"] == pytest.approx(8.0, abs=0.3)      # README: about 8.3 s of drive
    # the odd law softens (k3 < 0; k_s > 0), as the level-dependent sines say
    params = json.loads((tmp_path / "model.json").read_text())["parameters"]
    for name, sign in ODD_SOFTENING.items():
        if name in named:
            assert sign * params[SOFTENING_PARAM[name]]["value"] > 0, (name, params)
