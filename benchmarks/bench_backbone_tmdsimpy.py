"""Benchmark: labjoint's EPMC beside tmdsimpy's (Porter and Brake, tmd-lab/tmdsimpy) on one
system, tmdsimpy's own 2-DOF Jenkins test system (M = I, K = [[2, -1], [-1, 2]],
C = 0.01 M, a Jenkins element k_t = 0.25 N/m, F_s = 0.2 N from DOF 2 to ground).

tmdsimpy is not a dependency: give its source directory (a checkout of
github.com/tmd-lab/tmdsimpy; numpy and scipy only for these parts). Both solve EPMC with
harmonics 0-3 and 128 AFT samples per period at 50 amplitudes, each from the previous
solution (tmdsimpy's amplitude is log10 of the mass-normalised modal amplitude; its
solutions are converted to the fundamental's displacement amplitude at DOF 2, labjoint's
amplitude measure, and labjoint is solved at those). Reported: largest relative
differences in frequency and damping ratio (issue 30: within 0.5 % and 2 %) and the wall
time of each for the 50 points (ratio within this process; the machine's load).

Run: ``python benchmarks/bench_backbone_tmdsimpy.py TMDSIMPY_DIR [--smoke]``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from labjoint.structure.epmc import EPMC  # noqa: E402
from labjoint.structure.law import JointLaw  # noqa: E402
from labjoint.structure.system import LawElement, NonlinearSystem  # noqa: E402

KT, FS, H, NT = 0.25, 0.2, 3, 128


def tmdsimpy_backbone(log_amps: np.ndarray):
    from tmdsimpy.nlforces.vector_jenkins import VectorJenkins
    from tmdsimpy.solvers import NonlinearSolver
    from tmdsimpy.vibration_system import VibrationSystem

    M, K = np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]])
    vs = VibrationSystem(M, K, ab=[0.01, 0])
    vs.add_nl_force(VectorJenkins(np.array([[0.0, 1.0]]), np.array([[0.0], [1.0]]), KT, FS))
    solver = NonlinearSolver()
    lam, vec = solver.eigs(K, M=M, subset_by_index=[0, 0])
    h = np.arange(H + 1)
    nhc = 2 * H + 1
    U = np.zeros(2 * nhc)
    U[2:4] = vec[:, 0]
    Fl = np.zeros(2 * nhc)
    Fl[4:6] = 1.0                                   # phase: the sine part of harmonic 1
    X = np.hstack((U, np.sqrt(lam[0]), 0.01))
    out = []
    for a in log_amps:
        fun = lambda Uwx: vs.epmc_res(np.hstack((Uwx, a)), Fl, h, Nt=NT, aft_tol=1e-7)[0:2]  # noqa: E731
        X, _, _, sol = solver.nsolve(fun, X, verbose=False)
        if not sol["success"]:
            raise RuntimeError(f"tmdsimpy did not converge at log10 a = {a}")
        w, xi = X[-2], X[-1]
        amp = 10 ** a * abs(X[2 + 1] - 1j * X[4 + 1])      # DOF 2, harmonic 1 (cos, sin rows)
        out.append((amp, w / (2 * np.pi), xi / (2 * w)))
    return np.array(out)


def labjoint_backbone(amps: np.ndarray) -> np.ndarray:
    law = JointLaw("coulomb", {"coulomb.k": KT, "coulomb.f_s": FS})
    M, K = np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]])
    sysm = NonlinearSystem(M, 0.01 * M, K, np.array([0.0, 1.0]), np.array([[0.0, 1.0]]),
                           (LawElement(law),), np.eye(2), ("x1", "x2"))
    b, _ = EPMC(sysm, 0, H, NT, "x2").backbone(amps)
    return np.column_stack([b.array("amplitude"), b.array("frequency_hz"), b.array("damping_ratio")])


def main(argv: list[str]) -> int:
    dirs = [a for a in argv if not a.startswith("--")]
    if not dirs:
        print(__doc__)
        return 2
    sys.path.insert(0, dirs[0])
    n = 8 if "--smoke" in argv else 50
    with open("/proc/loadavg") as fh:
        load = " ".join(fh.read().split()[:3])
    log_amps = np.linspace(-0.5, 1.5, n)              # stuck (slip at 0.8 m) to macro-slip
    tmdsimpy_backbone(log_amps[:2])                   # warm-up
    labjoint_backbone(np.array([0.1, 0.2]))
    t = time.perf_counter()
    theirs = tmdsimpy_backbone(log_amps)
    t_theirs = time.perf_counter() - t
    t = time.perf_counter()
    ours = labjoint_backbone(theirs[:, 0])
    t_ours = time.perf_counter() - t
    df = np.abs(ours[:, 1] / theirs[:, 1] - 1)
    dz = np.abs(ours[:, 2] / theirs[:, 2] - 1)
    print(f"load {load}; {n} amplitudes {theirs[0, 0]:.3g}-{theirs[-1, 0]:.3g} m at DOF 2: frequency "
          f"{theirs[0, 1]:.5g} -> {theirs[-1, 1]:.5g} Hz, damping {theirs[0, 2]:.4g} -> {theirs[-1, 2]:.4g}")
    print(f"largest difference labjoint vs tmdsimpy: frequency {df.max():.2e} (goal 5e-3), damping "
          f"{dz.max():.2e} (goal 2e-2)")
    print(f"time for {n} points: labjoint {t_ours:.2f} s, tmdsimpy {t_theirs:.2f} s "
          f"(ratio {t_ours / t_theirs:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
