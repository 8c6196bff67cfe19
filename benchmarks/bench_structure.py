"""Benchmark: the structure layer against seed 000 and closed forms (one run, this machine).

1. Seed 000 Tables 1 and 3: free-free long pipe and the assembly's first two bending
   modes before and after stage-1 updating.
2. Table 2's shape: the steady response at 20 Hz (16.5 N at the free end, Richard-Abbott
   E_p = S_Y = 1e6 Pa, n = 5, E_e from stage 1) by harmonic balance on the unreduced
   model and Craig-Bampton with 5 and 30 kept modes: time and error.
3. Jenkins SDOF: one-harmonic HBM against the exact describing function (max error along
   a continuation), continuation points per second, multi-harmonic HBM against Newmark
   time integration to steady state (error and time ratio).

Figures (ratios in this process): Craig-Bampton HBM against the unreduced HBM (speed-up,
median of repeats), HBM against Newmark to steady state, the describing-function error.
Run: ``python benchmarks/bench_structure.py [--repeats 3] [--smoke]`` (smoke: one harmonic
in Table 2, a shorter continuation, one Newmark frequency).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.structure import load_structure, modes, structure_from_dict, update_stiffness  # noqa: E402
from labjoint.structure.continuation import continuation  # noqa: E402
from labjoint.structure.hbm import HarmonicBalance  # noqa: E402
from labjoint.structure.modal import with_parameter  # noqa: E402
from labjoint.structure.reduction import reduced_system  # noqa: E402
from labjoint.structure.system import NonlinearSystem  # noqa: E402
from labjoint.structure.timeint import steady_state  # noqa: E402
from test_structure_hbm import describing_function_force, jenkins  # noqa: E402

SEED000 = ROOT / "configs" / "structure-seed000.toml"


def tables_1_and_3() -> float:
    d = {"structure": {"element_length_m": 0.01}, "materials": {"s": {"E_pa": 215e9, "rho_kg_m3": 7800}},
         "sections": {"p": {"od_m": 0.114, "wall_m": 0.0038}},
         "components": {"b": {"section": "p", "material": "s", "length_m": 1.08}},
         "excitation": {"component": "b", "x_m": 1.08}, "sensors": [{"name": "e", "component": "b", "x_m": 1.08}]}
    ff = modes(structure_from_dict(d), 4).frequencies_hz[2:]
    print(f"Table 1 free-free long pipe: measured 568.7 905 940 1070 Hz; beam model "
          f"{ff[0]:.1f} {ff[1]:.1f} Hz (905-1070 Hz are shell modes a beam has not)")
    r = update_stiffness(load_structure(SEED000), [28.5, 177.0])
    print(f"Table 3: initial {r.initial_hz[0]:.2f}/{r.initial_hz[1]:.2f} Hz (paper 32.90/203.26), "
          f"updated {r.updated_hz[0]:.2f}/{r.updated_hz[1]:.2f} Hz (paper 28.49/177.00, measured "
          f"28.50/177.00), E_e {r.initial:.3g} -> {r.value:.3g} Pa in {len(r.history)} iterations")
    return r.value


def table_2(bench: Bench, e_e: float, harmonics: int = 3) -> None:
    s = with_parameter(load_structure(SEED000), "E_e_pa", e_e)
    s = with_parameter(s, "richard_abbott.kp", 1e6 * s.joints[0].layer.area(0.057) / 0.001)
    s = with_parameter(s, "richard_abbott.F_y", 1e6 * s.joints[0].layer.area(0.057))
    s = with_parameter(s, "richard_abbott.n", 5.0)
    w = 2 * np.pi * 20.0
    rows = []
    for label, sysm in (("no reduction", NonlinearSystem.from_structure(s)),
                        ("5 modes", reduced_system(s, 5)[0]), ("30 modes", reduced_system(s, 30)[0])):
        hb = HarmonicBalance(sysm, harmonics, 256)
        t = bench.repeat(lambda: hb.solve(w, 16.5))
        dt = t.median
        rows.append((label, sysm.n, dt, abs(hb.phasors(t.result)[1, -1])))
    ref = rows[0][3]
    print(f"Table 2 shape (HBM, {harmonics} harmonics, 20 Hz, 16.5 N):")
    for label, n, dt, amp in rows:
        err = "" if label == "no reduction" else f"  error {100 * abs(amp / ref - 1):.3f} %"
        print(f"  {label:13s} {n:4d} DOF  {dt:7.3f} s  response {amp:.4e} m  "
              f"speed-up {rows[0][2] / dt:6.1f}x{err}")
        if label != "no reduction":
            bench.figure(f"Table 2 HBM, Craig-Bampton {label} / unreduced", rows[0][2] / dt,
                         f"the unreduced model's HBM ({rows[0][1]} DOF): speed-up", value=dt,
                         unit="s", error_pct=100 * abs(amp / ref - 1))


def jenkins_sdof(bench: Bench, f_stop: float = 40.0, newmark_hz=(22.0, 26.0)) -> None:
    hb = HarmonicBalance(jenkins(0.3), 1, 1024)
    t0 = time.perf_counter()
    c = continuation(hb, 8.0, 10.0, f_stop)
    dt = time.perf_counter() - t0
    A = np.abs(c.phasors()[:, 1, 0])
    err = max(abs(describing_function_force(a, 2 * np.pi * f, 0.3) / 8.0 - 1) for a, f in zip(A, c.frequencies_hz))
    print(f"Jenkins SDOF, 1 harmonic: max describing-function error {100 * err:.2e} % over "
          f"{A.size} points, {A.size / dt:.0f} continuation points/s")
    bench.figure("Jenkins SDOF HBM, describing-function error", err,
                 "the exact describing function (max relative error over the continuation)",
                 value=A.size / dt, unit="continuation points/s")
    sysm = jenkins(8.0)
    hb = HarmonicBalance(sysm, 7, 512)
    for f in newmark_hz:
        t0 = time.perf_counter()
        P = hb.phasors(hb.solve(2 * np.pi * f, 4.0))[:, 0]
        th = time.perf_counter() - t0
        t0 = time.perf_counter()
        ss = steady_state(sysm, 4.0, f, 7, 256, tol=1e-7)
        tt = time.perf_counter() - t0
        e1 = abs(ss.phasors[1, 0] - P[1]) / abs(P[1])
        e3 = abs(ss.phasors[3, 0] - P[3]) / abs(P[3])
        print(f"  {f:.0f} Hz, 7 harmonics vs Newmark ({ss.periods} periods): harmonic 1 {100 * e1:.3f} %, "
              f"harmonic 3 {100 * e3:.2f} %; HBM {tt / th:.0f}x faster")
        bench.figure(f"Newmark to steady state / HBM at {f:g} Hz", tt / th,
                     "7-harmonic HBM of the same point (how many times slower)", value=tt,
                     unit="s (Newmark)", error_h1_pct=100 * e1)


def main() -> None:
    args = parser(__doc__).parse_args()
    bench = Bench.from_args("structure", args, repeats=3)
    bench.numba = "compilation excluded: each solve is timed after a first call (repeats)"
    e_e = tables_1_and_3()
    bench.warm_up(lambda: HarmonicBalance(jenkins(8.0), 1, 64).solve(2 * np.pi * 22.0, 4.0),
                  "a 1-harmonic HBM solve")
    if args.smoke:
        table_2(bench, e_e, harmonics=1)
        jenkins_sdof(bench, f_stop=14.0, newmark_hz=(26.0,))
    else:
        table_2(bench, e_e)
        jenkins_sdof(bench)
    bench.finish()


if __name__ == "__main__":
    main()
