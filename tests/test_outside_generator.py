"""Files from an outside generator: not the simulated rig, not the project's own synthetic
runs. A Jenkins joint (spring in series with a Coulomb slider) in parallel with a spring,
plus viscous damping the baseline lacks, written as CSV in the import format with only a
torque line of metadata (frequency and sample rate left for the tool to find), a 10-cycle
ramp-in, noise, and a DC offset on the displacement as a DC-coupled capacitive sensor
reads its gap. ``diagnose`` must find the viscous damping and recover c (slow, ~15 s)."""

import numpy as np
import pytest

from labjoint.compare import diagnose_report

FS = 20000.0
K_SLIP, F_SLIP, K_PAR, C_TRUE = 12e6, 50.0, 2e6, 200.0
GAP = 30e-6


def write_run(path, f, U, seed, cycles=40):
    rng = np.random.default_rng(seed)
    n = int(round(cycles * FS / f))
    t = np.arange(n) / FS
    ramp = np.clip(t * f / 10, 0, 1)
    u = U * ramp * (np.sin(2 * np.pi * f * t) + 0.02 * np.sin(6 * np.pi * f * t + 0.3))
    v = np.gradient(u, t)
    q, F = 0.0, np.empty(n)
    for i in range(n):
        q = min(max(q + K_SLIP * (u[i] - (u[i - 1] if i else 0.0)), -F_SLIP), F_SLIP)
        F[i] = q + K_PAR * u[i] + C_TRUE * v[i]
    um = u + GAP + rng.normal(0, 5e-9, n)
    Fm = F + rng.normal(0, 0.3, n)
    with open(path, "w") as fh:
        fh.write("# torque_nm: 5\n# source: outside generator\ntime_s,displacement_m,force_N\n")
        np.savetxt(fh, np.column_stack([t, um, Fm]), fmt="%.9g", delimiter=",")


@pytest.mark.slow
def test_diagnose_finds_viscous_damping_in_outside_csv_files(tmp_path):
    paths = []
    for i, f in enumerate((200.0, 400.0, 700.0)):
        for j, U in enumerate((3e-6, 6e-6, 9e-6)):
            p = tmp_path / f"ext_{f:g}Hz_{U * 1e6:g}um.csv"
            write_run(p, f, U, 10 * i + j)
            paths.append(p)
    d = diagnose_report(paths, "linear_stiffness+coulomb")
    assert not d.adequate
    best = d.candidates[0]
    assert best.effect == "viscous" and best.significant, d.verdict
    assert best.fit.params_["viscous.c"].value == pytest.approx(C_TRUE, rel=0.05)
    assert best.nrmse_after <= 1.5 * d.noise.nrmse
    # the sensor's gap is taken off: each record starts at rest at the gap
    refs = [r.run.metadata["displacement_reference_m"] for r in d.evaluation.runs]
    assert refs == pytest.approx([GAP] * len(paths), abs=0.05e-6)
