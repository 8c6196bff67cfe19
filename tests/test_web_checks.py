"""The dashboard's own checks (issue 33 items 2-4), its modules imported in a real
headless Chromium: a parameter whose standard error exceeds its value, or whose
covariance is singular, is flagged; a loop's sliding plateau is found (against a Jenkins
element's closed form) and an elliptic loop has none; a ladder step that made a run's
energy loss worse is named; refusals group by reason; the heat map names each column's
torque."""

from __future__ import annotations

import pytest

from labjoint.api import ApiSettings, create_app
from test_api_helpers import live_server
from test_web_support import chromium, open_page

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    app = create_app(ApiSettings(data_dir=tmp_path_factory.mktemp("checks")))
    with live_server(app) as url, chromium() as browser:
        yield url, browser


def _jenkins_loop(n: int = 400, k: float = 1e7, slip_n: float = 30.0, amp_m: float = 8e-6):
    """One steady cycle of a Jenkins element (spring k in series with a Coulomb slider of
    strength slip_n) under u = U sin: written here, independent of labjoint's effects.
    Sliding whenever |F| reaches slip_n, so the loop plateaus (gross slip)."""
    import math
    u = [amp_m * math.sin(2 * math.pi * i / n) for i in range(2 * n)]
    F, z = [], 0.0
    for i in range(1, len(u)):
        trial = k * (u[i] - z)
        if abs(trial) > slip_n:
            z = u[i] - math.copysign(slip_n, trial) / k
            trial = math.copysign(slip_n, trial)
        F.append(trial)
    return u[n:], F[n - 1:]                                # the second (steady) cycle


def test_the_pages_own_checks_flag_what_is_not_determined(served):
    """Items 2-4 in the page's own modules: a std. error above the value, or a singular
    covariance, is flagged; a plateau is found on a Jenkins loop and not on an ellipse;
    refusals group by reason; the heat map names the torque of each column."""
    import math
    url, browser = served
    u, F = _jenkins_loop()
    n = len(u)
    ellipse = {"displacement_m": [8e-6 * math.sin(2 * math.pi * i / n) for i in range(n)],
               "force_n": [80 * math.sin(2 * math.pi * i / n) + 30 * math.cos(2 * math.pi * i / n)
                           for i in range(n)]}
    w = open_page(browser, url)
    got = w.page.evaluate("""async ([jenkins, ellipse]) => {
      const mp = await import('/static/js/views/modelplots.js');
      const t2 = await import('/static/js/views/table2.js');
      const tr = await import('/static/js/views/trends.js');
      const det = [{ value: 1.26e6, stderr: 8.8e6 }, { value: 7.1e-4, stderr: 1.4e-12 },
        { value: 2e5, stderr: null }, { value: 2e5, stderr: 1e3 }].map((p) => mp.determination(p)[0]);
      const table = mp.parameters({ parameters: { 'linear_stiffness.k': { value: 1.26e6, stderr: 8.8e6, unit: 'N/m' },
        'inertia.m': { value: 7.1e-4, stderr: 1.4e-12, unit: 'kg' } } });
      mp.rememberRuns([{ name: 'a', torque_nm: 2 }, { name: 'b', torque_nm: 5 }, { name: 'c', torque_nm: 8 }]);
      const maps = mp.residualMaps({ by_run: { frequencies_hz: [400], amplitude_m: [[3.48e-7, 3.48e-7, 3.48e-7]],
        nrmse: [[0.1, 0.2, 0.3]], noise_floor: [[0.01, 0.01, 0.01]], runs: [['a', 'b', 'c']] } }, [], 'sine');
      const cols = [...maps.querySelectorAll('svg[data-plot=residual-grid] text.col-label')].map((t) => t.textContent);
      const groups = tr.groupErrors([
        { run: 'r1', error: "'excitation': run r1 (force_ref) holds a multisine with period 0.05 s and 50 excited lines" },
        { run: 'r22', error: "'excitation': run r22 (force_ref) holds a multisine with period 0.2 s and 193 excited lines" },
        { run: 'r3', error: "r3.h5, 'disp_1': run has no channel 'disp_1'; channels: ['force_ref', 'accel']" }]);
      const steps = [{ model: 'linear_stiffness', runs: [{ run: 'v1', energy_loss_error_pct: -40 }, { run: 'v20', energy_loss_error_pct: -30 }] },
        { model: 'linear_stiffness+iwan', added: 'iwan', runs: [{ run: 'v1', energy_loss_error_pct: -2.9 }, { run: 'v20', energy_loss_error_pct: 1 }] },
        { model: 'linear_stiffness+iwan+cubic_stiffness', added: 'cubic_stiffness', runs: [{ run: 'v1', energy_loss_error_pct: -12.3 }, { run: 'v20', energy_loss_error_pct: 1.5 }] }];
      const worse = mp.worseSteps(steps);
      const note = mp.worseNote(steps);
      return { worse, noteText: note ? note.textContent : null, none: mp.worseNote(steps.slice(0, 2)), det, se: [...table.querySelectorAll('tbody tr')].map((r) => [r.dataset.determination, r.children[2].textContent]),
        jenkins: t2.slidingFraction([jenkins]), ellipse: t2.slidingFraction([ellipse]), cols,
        groups: groups.map((g) => g.runs) };
    }""", [{"displacement_m": u, "force_n": F}, ellipse])
    assert got["det"] == ["poor", "undetermined", "undetermined", "ok"]
    assert got["se"] == [["poor", "8.8"], ["undetermined", "NaN"]]      # MN/m shown; no ±1.4e-12
    # the Jenkins loop slides once the force has reversed by 2 F_s after a reversal, at
    # sin(phase) = 1 - 2 r (r = F_s / (k U)), until the next reversal: 1/2 + asin(1 - 2r)/pi
    r = 30.0 / (1e7 * 8e-6)
    expect = 0.5 + math.asin(1 - 2 * r) / math.pi
    assert got["jenkins"] == pytest.approx(expect, abs=0.03)
    assert got["ellipse"] < 0.02                    # well under the 5 % the page flags at
    assert got["cols"] == ["0.348 µm · 2 N m", "0.348 µm · 5 N m", "0.348 µm · 8 N m"]
    assert sorted(got["groups"]) == [["r1", "r22"], ["r3"]]
    # item 4: the step that took the 1 Vpp run's energy-loss error from -2.9 % to -12.3 %
    assert [(x["step"], x["run"], x["before"], x["after"]) for x in got["worse"]] == [
        (2, "v1", -2.9, -12.3)]
    assert "-2.9 % → -12.3 %" in got["noteText"] and got["none"] is None
    assert not w.problems(), w.problems()
