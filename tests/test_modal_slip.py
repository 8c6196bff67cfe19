"""Micro-slip in the modal model (issue 29 item 8): a Masing law (Segalman's Iwan) acting in
the modal simulator, against an independent generator written here: a 2-DOF chain with a
joint between its masses made of Jenkins elements in parallel (a spring in series with a
slider each; no labjoint law), integrated by scipy's solve_ivp in physical coordinates.

The joint's elements discretise Segalman's density rho(phi) = R phi^chi on (0, phi_max)
plus S delta(phi - phi_max) (an element slipping at relative displacement phi, stiffness
rho dphi), whose stuck stiffness and macro-slip force are the integrals
K_T = R phi_max^(chi+1) / (chi+1) + S and F_S = R phi_max^(chi+2) / (chi+2) + S phi_max,
and beta = S (chi+1) / (R phi_max^(chi+1)) (Segalman 2005, via seed 001). The modal model
gets only what `labjoint modes` would measure at a low level, where the joint sticks: the
modes of the chain with the joint's stuck stiffness K_T; the law it needs is then what the
joint adds to them, -K_T u + iwan(u)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import eigh

from labjoint.compare.kinds.modal_fit import _starts, amplitude_levels
from labjoint.models import Model
from labjoint.structure.nlmode import Drive, MeasuredMode, ModalBasis
from labjoint.structure.nlmode_pair import pair_response, pair_states

M = np.diag([1.0, 0.5])
K0 = np.array([[5.5e4, -1.5e4], [-1.5e4, 1.5e4]])   # the chain without its joint (N/m)
ZETA = np.array([0.01, 0.008])
PHI_MAX, CHI, BETA_S = 2.0e-4, -0.6, 0.25           # the joint: slip range, exponent, delta's share
R_PHI = 6.0e3                                        # R phi_max^(chi+1) (N/m)
S = BETA_S * R_PHI / (CHI + 1)                       # the delta's stiffness (N/m)
K_T = R_PHI / (CHI + 1) + S
F_S = R_PHI * PHI_MAX / (CHI + 2) + S * PHI_MAX
GAIN = 10.0                                          # N per volt at mass 1
FS = 400.0
TONES = ((9.0, 0.5, 0.3), (14.0, 0.6, 1.1), (31.0, 0.2, 2.0))   # f (Hz), amplitude (V), phase


def _elements(n: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness (N/m) and slip displacement (m) of each Jenkins element: geometric bins on
    (1e-3, 1) phi_max, each bin's stiffness R int phi^chi dphi at its stiffness-weighted
    mean slip, one element for (0, 1e-3 phi_max) and the delta."""
    e = np.geomspace(1e-3, 1.0, n + 1)
    lo, hi = e[:-1], e[1:]
    w = (hi ** (CHI + 1) - lo ** (CHI + 1)) / (CHI + 1)
    x = (hi ** (CHI + 2) - lo ** (CHI + 2)) / (CHI + 2) / w
    w0 = e[0] ** (CHI + 1) / (CHI + 1)
    x0 = e[0] ** (CHI + 2) / (CHI + 2) / w0
    k = R_PHI * np.r_[w0, w, BETA_S / (CHI + 1)]
    return k, PHI_MAX * np.r_[x0, x, 1.0]


def _stuck_modes():
    K = K0 + K_T * np.array([[1.0, -1.0], [-1.0, 1.0]])
    w2, phi = eigh(K, M)                                 # mass-normalised
    return K, w2, phi


def volts(t, level):
    return level * sum(a * np.sin(2 * np.pi * f * t + p) - a * np.sin(p) * np.exp(-3 * t)
                       for f, a, p in TONES)


def _reference(level: float, seconds: float = 3.0, rtol: float = 1e-6):
    """Displacement and acceleration of both masses (solve_ivp, the joint's elements as
    states: each element's spring extension e, held at its slip displacement while the
    motion loads it further)."""
    k_el, ph = _elements()
    K, w2, phi = _stuck_modes()
    C = M @ phi @ np.diag(2 * ZETA * np.sqrt(w2)) @ phi.T @ M
    Mi = np.linalg.inv(M)

    A, B = Mi @ K0, Mi @ C

    def rhs(t, s):
        e = s[4:]
        du = s[2] - s[3]
        F = float(k_el @ np.clip(e, -ph, ph))
        out = np.empty_like(s)
        out[:2] = s[2:4]
        out[2:4] = Mi @ np.array([GAIN * volts(t, level) - F, F]) - B @ s[2:4] - A @ s[:2]
        out[4:] = np.where((np.abs(e) >= ph) & (e * du > 0), 0.0, du)
        return out

    t = np.arange(int(seconds * FS)) / FS
    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(4 + k_el.size), t_eval=t, method="RK45",
                    rtol=rtol, atol=1e-13, max_step=1 / FS)
    acc = np.array([rhs(ti, si)[2:4] for ti, si in zip(t, sol.y.T)])
    return t, sol.y[:2].T, acc


def _basis_and_law():
    _, w2, phi = _stuck_modes()
    ref = phi[0]                                          # sensor s1 (the drive point)
    modes = tuple(MeasuredMode(float(np.sqrt(w2[j]) / (2 * np.pi)), float(ZETA[j]),
                               {f"s{i + 1}": float(phi[i, j] / ref[j]) for i in range(2)})
                  for j in range(2))
    c = ref[0] ** 2                                       # per unit modal mass of mode 1
    law = {"linear_stiffness.k": -K_T * c, "iwan.F_S": F_S * c, "iwan.K_T": K_T * c,
           "iwan.chi": CHI, "iwan.beta": BETA_S}
    drives = {f"modal.drive{j + 1}": GAIN * ref[j] ** 2 for j in range(2)}
    drives["modal.mass2"] = ref[0] ** 2 / ref[1] ** 2
    return ModalBasis(modes, "s1"), law, drives


def _nrmse(m, r):
    return float(np.sqrt(np.mean((m - r) ** 2) / np.mean(r ** 2)))


def test_iwan_in_the_modal_simulator_is_the_jenkins_network():
    """The modal model with iwan between s1 and s2 reproduces the chain of Jenkins elements
    at a level where the joint micro-slips (and a linear joint does not)."""
    t, x, a = _reference(1.0, seconds=0.8, rtol=1e-5)
    u = x[:, 0] - x[:, 1]
    assert 0.05 * PHI_MAX < np.max(np.abs(u)) < 2 * PHI_MAX       # micro-slip, partly macro
    basis, law, drives = _basis_and_law()
    drive = Drive.of(volts(t, 1.0), FS, highest_hz=basis.modes[-1].frequency_hz)
    st = pair_states("linear_stiffness+iwan", {**law, **drives}, basis, ("s1", "s2"), drive)
    for i, s in enumerate(("s1", "s2")):
        assert _nrmse(pair_response(st, basis, s, "displacement"), x[:, i]) < 3e-3
        assert _nrmse(pair_response(st, basis, s, "acceleration"), a[:, i]) < 3e-3
    # the slip matters: the stuck joint (the measured modes alone) is far off
    lin = pair_states("linear_stiffness", {"linear_stiffness.k": 0.0, **drives}, basis, ("s1", "s2"), drive)
    assert _nrmse(pair_response(lin, basis, "s2", "displacement"), x[:, 1]) > 0.05


def test_slip_starts_span_the_records_amplitudes():
    """Slip laws start at the smallest record's amplitude as well as the largest."""
    lv = amplitude_levels([1e-5, 3e-4, 1e-2])
    assert lv[0] == 1e-5 and lv[-1] == 1e-2 and lv[1] == pytest.approx(np.sqrt(1e-7))
    k = 1e4
    for law, slip in (("coulomb", lambda d: d["coulomb.f_s"] / d["coulomb.k"]),
                      ("iwan", lambda d: d["iwan.F_S"] / d["iwan.K_T"])):
        st = _starts(Model.parse(f"linear_stiffness+{law}"), {"linear_stiffness.k": k}, [1e-5, 1e-2])
        s = sorted({round(float(np.log10(slip(d))), 1) for d in st})
        assert s[0] < -4.5 and s[-1] > -2.5, (law, s)
        # the stuck stiffness stays the measured one: k + the law's stuck stiffness = k
        kn = "coulomb.k" if law == "coulomb" else "iwan.K_T"
        assert all(d["linear_stiffness.k"] + d[kn] == pytest.approx(k) for d in st)
    # iwan is also started in micro-slip at every record: macro-slip (phi_max) 10x above the largest
    st = _starts(Model.parse("linear_stiffness+iwan"), {"linear_stiffness.k": k}, [1e-5, 1e-2])
    d_of = lambda d: d["iwan.beta"] + (d["iwan.chi"] + 1) / (d["iwan.chi"] + 2)  # noqa: E731
    phi = [d["iwan.F_S"] * (1 + d["iwan.beta"]) / (d["iwan.K_T"] * d_of(d)) for d in st]
    assert max(phi) == pytest.approx(10 * 1e-2) and min(phi) == pytest.approx(1e-5)


def _record(level: float, name: str):
    from labjoint.storage.channels import Channel, ChannelRecord
    t, x, a = _reference(level, seconds=2.5)
    rng = np.random.default_rng(int(level * 100))
    chans = {"v": Channel("v", volts(t, level), "voltage", "V", "drive")}
    for nm, qty, y, unit in (("s1", "acceleration", a[:, 0], "m/s^2"),
                             ("s2", "acceleration", a[:, 1], "m/s^2")):
        chans[nm] = Channel(nm, y + 1e-4 * y.std() * rng.standard_normal(y.size), qty, unit, "response")
    return ChannelRecord(name, t, FS, chans, {})


@pytest.mark.slow
def test_micro_slip_named_and_its_parameters_recovered():
    """Records of the Jenkins-network chain at three levels (from micro-slip to the edge of
    macro-slip; accelerations, 0.01 % noise): diagnose on the modal kind with the joint
    between s1 and s2, from the measured (stuck) modes, names iwan over cubic stiffness and
    coulomb, and its fit recovers the joint (per unit modal mass of mode 1)."""
    from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared
    from labjoint.compare.kinds.modal_prepare import prepare_modal
    basis, law, drives = _basis_and_law()
    recs = [_record(lv, f"L{lv:g}") for lv in (0.3, 1.0, 2.5)]
    ms = [prepare_modal(r, basis, between=("s1", "s2")) for r in recs]
    dg = diagnose_prepared(ms, "linear_stiffness",
                           settings=DiagnoseSettings(candidates=("cubic_stiffness", "coulomb", "iwan")))
    assert dg.candidates[0].effect == "iwan", [(c.effect, c.nrmse_after) for c in dg.candidates]
    fit = dg.candidates[0].fit                 # fitted on 0.3 and 2.5, validated on 1.0
    assert fit.validation_runs_ == ("L1",)
    v = fit.params_.valuesdict()
    assert fit.nrmse_ < 5e-3 and fit.validation_nrmse_ < 5e-3
    for k in ("iwan.K_T", "iwan.F_S", "linear_stiffness.k"):
        assert v[k] == pytest.approx(law[k], rel=0.05), k
    assert v["iwan.chi"] == pytest.approx(CHI, abs=0.1)
    assert v["iwan.beta"] == pytest.approx(BETA_S, abs=0.1)
