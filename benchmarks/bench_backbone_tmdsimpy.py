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

Without TMDSIMPY_DIR (e.g. ``--smoke`` alone, as the smoke test runs it) the peer is not
given: labjoint's side only, at the amplitudes tmdsimpy's would give (log10 modal amplitude
-0.5 .. 1.5, mode shape [1, 1]/sqrt 2 at DOF 2), timed against one linear modal solve of
the stuck system (K + k_t at DOF 2) in the same process, and its lowest amplitude's
frequency checked against that modal solve's (stuck: the same up to the damping).

Run: ``python benchmarks/bench_backbone_tmdsimpy.py [TMDSIMPY_DIR] [--smoke] [--repeats N]``
(smoke: 8 amplitudes).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.linalg

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.harness import Bench, parser  # noqa: E402
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


def stuck_modal_hz() -> float:
    """Mode 1 of the stuck system (the Jenkins spring k_t at DOF 2 to ground), Hz."""
    lam = scipy.linalg.eigh(np.array([[2.0, -1.0], [-1.0, 2.0 + KT]]), np.eye(2), eigvals_only=True)
    return float(np.sqrt(lam[0]) / (2 * np.pi))


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("tmdsimpy", nargs="?", default=None,
                    help="a tmdsimpy checkout (github.com/tmd-lab/tmdsimpy); without it, labjoint only")
    args = ap.parse_args()
    bench = Bench.from_args("backbone_tmdsimpy", args, repeats=3)
    n = 8 if args.smoke else 50
    log_amps = np.linspace(-0.5, 1.5, n)              # stuck (slip at 0.8 m) to macro-slip
    bench.warm_up(lambda: labjoint_backbone(np.array([0.1, 0.2])), "two labjoint EPMC points")
    if args.tmdsimpy is None:
        print("tmdsimpy not given (no TMDSIMPY_DIR): labjoint's side only, against one linear "
              "modal solve of the stuck system")
        amps = 10 ** log_amps / np.sqrt(2)            # modal amplitude x mode shape at DOF 2
        t_modal = bench.repeat(stuck_modal_hz, repeats=max(bench.repeats, 5))
        tm = bench.repeat(lambda: labjoint_backbone(amps))
        ours, f_lin = tm.result, t_modal.result
        print(f"{n} amplitudes {ours[0, 0]:.3g}-{ours[-1, 0]:.3g} m at DOF 2: frequency "
              f"{ours[0, 1]:.5g} -> {ours[-1, 1]:.5g} Hz, damping {ours[0, 2]:.4g} -> {ours[-1, 2]:.4g}; "
              f"stuck linear mode 1 {f_lin:.5g} Hz")
        print(f"time for {n} points: labjoint {tm.median:.3f} s (tmdsimpy not run)")
        bench.figure(f"labjoint EPMC, {n} points / one linear modal solve", tm.median / t_modal.median,
                     "one modal solve (scipy eigh) of the stuck 2-DOF system; tmdsimpy not given",
                     value=tm.median, unit="s", timing=tm)
        bench.figure("lowest-amplitude frequency / stuck linear mode 1", ours[0, 1] / f_lin,
                     "the stuck system's linear mode 1 (1 = stuck regime reproduced)",
                     value=ours[0, 1], unit="Hz")
        bench.finish(peer="tmdsimpy not given")
        return 0
    sys.path.insert(0, str(Path(args.tmdsimpy).resolve()))
    bench.warm_up(lambda: (tmdsimpy_backbone(log_amps[:2]), labjoint_backbone(np.array([0.1, 0.2]))),
                  "two EPMC points by each")
    walls_theirs, walls_ours = [], []
    for _ in range(bench.repeats):                    # alternating: both see the same load
        t_th = bench.repeat(lambda: tmdsimpy_backbone(log_amps), repeats=1)
        theirs = t_th.result
        t_us = bench.repeat(lambda: labjoint_backbone(theirs[:, 0]), repeats=1)
        ours = t_us.result
        walls_theirs.append(t_th.median)
        walls_ours.append(t_us.median)
    t_theirs, t_ours = float(np.median(walls_theirs)), float(np.median(walls_ours))
    df = np.abs(ours[:, 1] / theirs[:, 1] - 1)
    dz = np.abs(ours[:, 2] / theirs[:, 2] - 1)
    print(f"{n} amplitudes {theirs[0, 0]:.3g}-{theirs[-1, 0]:.3g} m at DOF 2: frequency "
          f"{theirs[0, 1]:.5g} -> {theirs[-1, 1]:.5g} Hz, damping {theirs[0, 2]:.4g} -> {theirs[-1, 2]:.4g}")
    print(f"largest difference labjoint vs tmdsimpy: frequency {df.max():.2e} (goal 5e-3), damping "
          f"{dz.max():.2e} (goal 2e-2)")
    print(f"time for {n} points: labjoint {t_ours:.2f} s, tmdsimpy {t_theirs:.2f} s "
          f"(ratio {t_ours / t_theirs:.2f}, medians of {bench.repeats}, alternating)")
    bench.figure("largest frequency difference / goal", df.max() / 5e-3,
                 "the 0.5 % goal (issue 30); difference relative to tmdsimpy's", value=df.max(),
                 unit="relative", target="<= 1")
    bench.figure("largest damping-ratio difference / goal", dz.max() / 2e-2,
                 "the 2 % goal (issue 30); difference relative to tmdsimpy's", value=dz.max(),
                 unit="relative", target="<= 1")
    bench.figure(f"labjoint / tmdsimpy EPMC, {n} points", t_ours / t_theirs,
                 "tmdsimpy's EPMC of the same points (median, alternating)", value=t_ours, unit="s",
                 reference_s=t_theirs)
    bench.finish(peer=str(args.tmdsimpy))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
