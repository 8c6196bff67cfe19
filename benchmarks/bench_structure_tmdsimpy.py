"""Benchmark: the same harmonic-balance FRF by labjoint and by tmdsimpy (issue 32 item 6).

One system: two masses (1 kg, 0.5 kg), springs 1e4 N/m to ground and 2e4 N/m between them,
Rayleigh damping, a cubic spring k3 = 1e8 N/m^3 on the relative displacement x2 - x1
(tmdsimpy: ``CubicForce`` with Q = [-1, 1], T = Q^T; labjoint: a ``cubic_stiffness`` law
on the selector [-1, 1]), harmonics 0-3, 64 time samples per period, 1 N at mass 2 (hardening without a fold). The
step sine goes up through mode 1 (each point from the previous one); for each frequency
both solve their own residual by Newton to 1e-10 (tmdsimpy's analytic AFT Jacobian,
labjoint's finite-difference one). Reported: the largest relative difference of the
harmonic-1 amplitude of x2 over the sweep (target <= 0.5 %) and the time per point.

tmdsimpy is not a dependency of labjoint: pass its checkout (``git clone
https://github.com/tmd-lab/tmdsimpy``) as ``--tmdsimpy PATH`` (its ``tmdsimpy`` package is
imported from there). Without ``--tmdsimpy`` (e.g. ``--smoke`` alone, as the smoke test runs
it) the peer is not given: labjoint's sweep only, its time per point against one linear
complex solve per point of the same system (the underlying linear FRF) in this process, and
its lowest point (10 Hz, well below mode 1) against that linear FRF.

Run: ``python benchmarks/bench_structure_tmdsimpy.py [--tmdsimpy PATH] [--smoke] [--repeats N]``
(smoke: 16 points over the same band).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.structure.hbm import HarmonicBalance  # noqa: E402
from labjoint.structure.law import JointLaw  # noqa: E402
from labjoint.structure.system import LawElement, NonlinearSystem  # noqa: E402

M = np.diag([1.0, 0.5])
K = np.array([[1e4 + 2e4, -2e4], [-2e4, 2e4]])
C = 0.5 * M + 1e-5 * K
Q = np.array([[-1.0, 1.0]])
K3, F, H, NT = 1e8, 1.0, 3, 64


def labjoint_sweep(freqs: np.ndarray) -> tuple[np.ndarray, float]:
    law = JointLaw("cubic_stiffness", {"cubic_stiffness.k3": K3})
    sysm = NonlinearSystem(M, C, K, np.array([0.0, 1.0]), Q.copy(), (LawElement(law),),
                           np.eye(2), ("x1", "x2"))
    hb = HarmonicBalance(sysm, H, NT)
    out, x = [], None
    t = time.perf_counter()
    for f in freqs:
        x = hb.solve(2 * np.pi * f, F, x0=x, tol=1e-10)
        out.append(abs(hb.phasors(x)[1, 1]))
    return np.array(out), (time.perf_counter() - t) / freqs.size


def tmdsimpy_sweep(freqs: np.ndarray) -> tuple[np.ndarray, float]:
    from tmdsimpy.nlforces.cubic_stiffness import CubicForce
    from tmdsimpy.vibration_system import VibrationSystem
    vs = VibrationSystem(M, K, C)
    vs.add_nl_force(CubicForce(Q, Q.T, np.array([K3])))
    h = np.arange(H + 1)
    n, nhc = 2, 2 * H + 1
    Fl = np.zeros(n * nhc)
    Fl[n + 1] = F                                # harmonic-1 cosine at mass 2
    U = np.zeros(n * nhc)
    out = []
    t = time.perf_counter()
    for f in freqs:
        w = 2 * np.pi * f
        for _ in range(60):                      # Newton on tmdsimpy's residual and Jacobian
            R, dRdU, _ = vs.hbm_res(np.r_[U, w], Fl, h, Nt=NT)
            if np.linalg.norm(R) < 1e-10 * F:
                break
            U = U - np.linalg.solve(dRdU, R)
        else:
            raise RuntimeError(f"tmdsimpy Newton did not converge at {f} Hz")
        out.append(np.hypot(U[n + 1], U[2 * n + 1]))
    return np.array(out), (time.perf_counter() - t) / freqs.size


def linear_sweep(freqs: np.ndarray) -> tuple[np.ndarray, float]:
    """|X2| of the linear system (no cubic spring): one complex solve per frequency."""
    out = []
    t = time.perf_counter()
    for f in freqs:
        w = 2 * np.pi * f
        out.append(abs(np.linalg.solve(K - w ** 2 * M + 1j * w * C, np.array([0.0, F]))[1]))
    return np.array(out), (time.perf_counter() - t) / freqs.size


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("--tmdsimpy", default=None,
                    help="path of a tmdsimpy checkout (without it: labjoint only)")
    args = ap.parse_args()
    bench = Bench.from_args("structure_tmdsimpy", args, repeats=3)
    freqs = np.linspace(10.0, 25.0, 16 if args.smoke else 61)
    f_lin = np.sqrt(np.linalg.eigvals(np.linalg.solve(M, K)).min()) / 2 / np.pi
    bench.warm_up(lambda: labjoint_sweep(freqs[:2]), "two labjoint HBM points")
    if args.tmdsimpy is None:
        print("tmdsimpy not given (no --tmdsimpy): labjoint's sweep only, against one linear "
              "complex solve per point")
        ref = bench.repeat(lambda: linear_sweep(freqs))
        tm = bench.repeat(lambda: labjoint_sweep(freqs))
        a, lin = tm.result[0], ref.result[0]
        ta = tm.median_of([r[1] for r in tm.results])
        tl = ref.median_of([r[1] for r in ref.results])
        print(f"{freqs.size} points, {freqs[0]:g}-{freqs[-1]:g} Hz; peak |X2| {a.max():.4g} m at "
              f"{freqs[np.argmax(a)]:.3g} Hz (linear mode 1 {f_lin:.3g} Hz)")
        print(f"time per point: labjoint {1e3 * ta:.2f} ms (tmdsimpy not run), linear solve "
              f"{1e3 * tl:.4f} ms")
        bench.figure("labjoint HBM time per point / one linear solve", ta / tl,
                     "one complex linear solve per point (the linear FRF); tmdsimpy not given",
                     value=1e3 * ta, unit="ms per point", timing=tm)
        bench.figure("|X2| at 10 Hz, labjoint HBM / linear FRF", a[0] / lin[0],
                     "the linear FRF (cubic spring off) well below mode 1 (~1: small hardening)",
                     value=a[0], unit="m")
        bench.finish(peer="tmdsimpy not given")
        return 0
    sys.path.insert(0, str(Path(args.tmdsimpy).resolve()))
    bench.warm_up(lambda: (tmdsimpy_sweep(freqs[:2]), labjoint_sweep(freqs[:2])),
                  "two HBM points by each")
    per_a, per_b = [], []
    for _ in range(bench.repeats):                # alternating: both see the same load
        a, ta = labjoint_sweep(freqs)
        b, tb = tmdsimpy_sweep(freqs)
        per_a.append(ta)
        per_b.append(tb)
    ta, tb = float(np.median(per_a)), float(np.median(per_b))
    err = np.max(np.abs(a / b - 1))
    print(f"{freqs.size} points, {freqs[0]:g}-{freqs[-1]:g} Hz; peak |X2| {a.max():.4g} m at "
          f"{freqs[np.argmax(a)]:.3g} Hz (linear mode 1 {f_lin:.3g} Hz)")
    print(f"largest relative difference of |X2| (harmonic 1): {100 * err:.2g} %")
    print(f"time per point: labjoint {1e3 * ta:.2f} ms, tmdsimpy {1e3 * tb:.2f} ms "
          f"(medians of {bench.repeats}, alternating)")
    bench.figure("largest |X2| difference / target", err / 5e-3,
                 "the 0.5 % target; difference relative to tmdsimpy's |X2| (harmonic 1)",
                 value=err, unit="relative", target="<= 1")
    bench.figure("time per point, labjoint / tmdsimpy", ta / tb,
                 "tmdsimpy's Newton on its own residual, same points (median, alternating)",
                 value=1e3 * ta, unit="ms per point", reference_ms=1e3 * tb)
    bench.finish(peer=str(args.tmdsimpy))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
