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
imported from there). Run: ``python benchmarks/bench_structure_tmdsimpy.py --tmdsimpy PATH``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

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


def main(path: str) -> None:
    sys.path.insert(0, str(Path(path).resolve()))
    freqs = np.linspace(10.0, 25.0, 61)
    a, ta = labjoint_sweep(freqs)
    b, tb = tmdsimpy_sweep(freqs)
    err = np.max(np.abs(a / b - 1))
    print(f"load {Path('/proc/loadavg').read_text().split()[:3]}")
    print(f"{freqs.size} points, {freqs[0]:g}-{freqs[-1]:g} Hz; peak |X2| {a.max():.4g} m at "
          f"{freqs[np.argmax(a)]:.3g} Hz (linear mode 1 {np.sqrt(np.linalg.eigvals(np.linalg.solve(M, K)).min()) / 2 / np.pi:.3g} Hz)")
    print(f"largest relative difference of |X2| (harmonic 1): {100 * err:.2g} %")
    print(f"time per point: labjoint {1e3 * ta:.2f} ms, tmdsimpy {1e3 * tb:.2f} ms")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tmdsimpy", required=True, help="path of a tmdsimpy checkout")
    main(ap.parse_args().tmdsimpy)
