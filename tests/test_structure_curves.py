"""Model FRFs evaluated densely beside the measured steps (issue 32 item 7; the curves the
page's structure view draws): :func:`labjoint.compare.frf_curves.dense_curves` and
``POST /structures/{name}/curves``.

Closed forms the curve must meet and a polyline through the five measured steps cannot:
with a linear joint the harmonic-1 accelerance peaks at the structure's first natural
frequency (the unreduced finite-element eigenproblem, not harmonic balance) with the
half-power bandwidth of the file's modal damping ratio (2 zeta f_n) and a phase of +90 deg
relative to the force, the same per newton at every level, with no higher harmonics.
A micro-slip (Iwan) joint softens and damps more as the force grows."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from frfdata import HIDDEN, hidden_law, hidden_set, predictor, write_linear_structure
from labjoint.api import ApiSettings, create_app
from labjoint.compare.frf_api import load_frf
from labjoint.compare.frf_curves import dense_curves
from labjoint.errors import InputError
from labjoint.structure.frf import response_at
from labjoint.structure.hbm import ConvergenceError
from labjoint.structure.predict import synthetic_frfset
from test_api_helpers import AUTH, CONTROL, live_server, wait_for
import patience
from labjoint.client import Client
from patience import http_client

ZETA = 0.005                   # the structure file's [damping] ratios
LINEAR = {"linear_stiffness.k": 1e10}


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("curves")
    (d / "structures").mkdir()
    (d / "frf").mkdir()
    write_linear_structure(d / "structures" / "lin.toml")
    hidden_set(predictor(), hidden_law(), steps=5).save(d / "frf" / "sweep.json")
    return SimpleNamespace(dir=d, sets=[str(d / "frf" / "sweep.json")],
                           opts={"structure": str(d / "structures" / "lin.toml"), "modes": 10})


def _arr(x) -> np.ndarray:
    return np.array(x, dtype=float)          # null (not converged) -> nan


def test_a_linear_joint_resonates_where_the_eigenproblem_says_with_the_files_damping(data):
    res = dense_curves(data.sets, "linear_stiffness", LINEAR, data.opts, points=400)
    ms, _ = load_frf(data.sets, None, data.opts)
    fn = float(ms[0].predictor.natural_frequencies(1)[0])
    assert len(res["sweeps"]) == 3                                      # 2, 5, 10 N around mode 1
    first = None
    for sw in res["sweeps"]:
        f, steps = _arr(sw["model"]["frequency_hz"]), _arr(sw["measured"]["frequency_hz"])
        assert sw["model"]["points"] == 400 and sw["model"]["not_converged_hz"] == []
        assert f.min() < steps.min() and f.max() > steps.max()           # between and around
        df = f[1] - f[0]
        # the steps miss the resonance: a curve through them could not find it
        assert np.min(np.abs(steps - fn)) > 10 * df
        for s, name in enumerate(sw["sensors"]):
            mag = _arr(sw["model"]["magnitude_per_n"][s])               # (H, n)
            i = int(np.argmax(mag[0]))
            assert abs(f[i] - fn) <= df, (name, f[i], fn)
            half = f[mag[0] >= mag[0, i] / np.sqrt(2)]
            assert (half.max() - half.min()) / (2 * fn) == pytest.approx(ZETA, rel=0.03), name
            assert sw["model"]["phase_deg"][s][0][i] == pytest.approx(90.0, abs=2.0), name
            assert np.all(mag[1:] == 0)                                 # a linear joint: no h2, h3
            assert np.isnan(_arr(sw["model"]["phase_deg"][s][1:])).all()
        h1 = _arr(sw["model"]["magnitude_per_n"])[:, 0]
        if first is None:
            first = h1
        else:                                                           # per newton: one curve
            np.testing.assert_allclose(h1, first, rtol=1e-6)


def test_a_micro_slip_joint_softens_and_damps_more_with_force(data):
    res = dense_curves(data.sets, "iwan+viscous", HIDDEN, data.opts, points=60, margin=0.1)
    peaks, heights = [], []
    for sw in sorted(res["sweeps"], key=lambda s: s["level_n"]):
        f = _arr(sw["model"]["frequency_hz"])
        mag = _arr(sw["model"]["magnitude_per_n"][sw["sensors"].index("free_end")][0])
        assert np.isfinite(mag).all()
        i = int(np.argmax(mag))
        y = np.log(mag[i - 1:i + 2])                     # the peak between grid points (parabola)
        peaks.append(f[i] + 0.5 * (y[0] - y[2]) / (y[0] - 2 * y[1] + y[2]) * (f[1] - f[0]))
        heights.append(mag[i])
        # the steps' measured phasors (hidden law + 0.5 % noise) sit on the same curve
        meas = _arr(sw["measured"]["magnitude_per_n"][sw["sensors"].index("free_end")][0])
        fm = _arr(sw["measured"]["frequency_hz"])
        np.testing.assert_allclose(np.interp(fm, f, mag), meas, rtol=0.05)
    assert peaks[0] > peaks[1] > peaks[2], peaks
    assert heights[0] > heights[1] > heights[2], heights


def test_bad_requests_name_the_field(data):
    with pytest.raises(InputError) as e:
        dense_curves(data.sets, "linear_stiffness", {"linear_stiffness.q": 1.0}, data.opts)
    assert e.value.field == "parameters" and "linear_stiffness.k" in e.value.message
    with pytest.raises(InputError) as e:
        dense_curves(data.sets, "linear_stiffness+wear", {}, data.opts)
    assert e.value.field in ("model", "parameters")
    with pytest.raises(InputError) as e:
        dense_curves(data.sets, "linear_stiffness", LINEAR, data.opts, points=5)
    assert e.value.field == "points"


def test_the_curves_job_over_rest(data):
    app = create_app(ApiSettings(data_dir=data.dir, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as http:
        r = http.post("/structures/lin/curves", json={"frfsets": ["sweep"], "model": "linear_stiffness",
                                                     "parameters": LINEAR, "points": 50, "modes": 4})
        assert r.status_code == 202, r.text
        job = wait_for(lambda: http.get(f"/structures/jobs/{r.json()['id']}").json(),
                       lambda j: j["status"] in ("complete", "failed"), timeout=120)
        assert job["status"] == "complete", job
        sw = job["result"]["sweeps"]
        assert [s["level_n"] for s in sw] == [2.0, 5.0, 10.0]
        assert all(len(s["model"]["frequency_hz"]) == 50 and len(s["measured"]["frequency_hz"]) == 5
                   for s in sw)
        assert sw[0]["units"] == "m/s^2/N" and len(sw[0]["model"]["phase_deg"]) == 3     # sensors
        bad = http.post("/structures/lin/curves", json={"frfsets": ["sweep"], "model": "linear_stiffness",
                                                       "parameters": {"viscous.c": 1.0}})
        assert bad.status_code == 422 and "linear_stiffness.k" in bad.text
        bad = http.post("/structures/lin/curves", json={"frfsets": ["sweep"], "model": "linear_stiffness",
                                                       "parameters": LINEAR, "points": 5})
        assert bad.status_code == 422
        assert http.post("/structures/lin/curves", json={"frfsets": ["nope"], "model": "linear_stiffness",
                                                         "parameters": LINEAR}).status_code == 404
        with Client(url, token=CONTROL, timeout=patience.HTTP_TIMEOUT_S) as c:
            res = c.structure_curves("lin", ["sweep"], "linear_stiffness", LINEAR, points=20, modes=4)
        assert [len(s["model"]["frequency_hz"]) for s in res["sweeps"]] == [20, 20, 20]


def test_response_at_takes_a_force_per_frequency_and_leaves_out_what_does_not_converge():
    """The building block of the curves: a force per frequency (linear joint: the response
    scales with it), and a frequency where Newton cannot meet the tolerance (here one
    below round-off) raises, or with ``skip_failed`` is NaN, never a made-up value."""
    sysm = predictor().system
    one = response_at(sysm, [39.0], 2.0, harmonics=1)[0]
    per = response_at(sysm, [38.0, 39.0, 40.0], [2.0, 4.0, 2.0], harmonics=1)
    np.testing.assert_allclose(per[1, 1], 2 * one[1], rtol=1e-6)
    with pytest.raises(ConvergenceError):
        response_at(sysm, [38.0, 39.0], 2.0, harmonics=1, tol=1e-30)
    assert np.isnan(response_at(sysm, [38.0, 39.0], 2.0, harmonics=1, tol=1e-30, skip_failed=True)).all()


def test_each_modes_sweeps_get_their_own_curve_at_that_modes_resonance(tmp_path, data):
    """A set with steps around modes 1 and 2: one curve per level and mode, each over its
    own steps, each resonating at its own natural frequency with the file's damping."""
    pr = predictor()
    fn = pr.natural_frequencies(2)
    f = np.concatenate([np.linspace(0.97, 1.03, 5) * fn[0], np.linspace(0.97, 1.03, 5) * fn[1]])
    synthetic_frfset(pr, None, f, [2.0, 10.0], harmonics=1, noise=0.005, seed=4).save(tmp_path / "two.json")
    res = dense_curves([str(tmp_path / "two.json")], "linear_stiffness", LINEAR, data.opts, points=300)
    assert sorted((s["mode"], s["level_n"]) for s in res["sweeps"]) == [(1, 2.0), (1, 10.0), (2, 2.0), (2, 10.0)]
    for sw in res["sweeps"]:
        g = _arr(sw["model"]["frequency_hz"])
        mag = _arr(sw["model"]["magnitude_per_n"][sw["sensors"].index("free_end")][0])
        target = fn[sw["mode"] - 1]
        assert g.min() < 0.97 * target and g.max() > 1.03 * target and g.max() < 1.1 * target
        assert abs(g[np.argmax(mag)] - target) <= g[1] - g[0], (sw["run"], target)
        half = g[mag >= mag.max() / np.sqrt(2)]
        assert (half.max() - half.min()) / (2 * target) == pytest.approx(ZETA, rel=0.05), sw["run"]
