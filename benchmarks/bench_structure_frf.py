"""Benchmark: seed 000's nonlinear FRF set, Craig-Bampton + HBM against unreduced HBM and
time integration to steady state (issue 15; one run, this shared 2-core machine).

The seed 000 assembly (configs/structure-seed000.toml) with a Richard-Abbott joint in
its nonlinear range at these forces (ke = 1e10 N/m, kp = 1e8 N/m, F_y = 3 kN, n = 2 per
thread: Table 4's S_Y gives a yield force of 200 kN, which 16.5 N never reaches in a beam
model). The FRF set: ``POINTS`` frequencies around each of modes 1 and 2 (0.9-1.05 x the
linear natural frequency), at 3 force levels, ``H`` harmonics, stepped up in sweep order
(each step from the previous solution, as the rig steps): 6 x ``POINTS`` solutions.

- CB + HBM: Craig-Bampton with 10 kept modes, ``H`` harmonics (``--harmonics``; default 7,
  the fewest that meet the 1 % goal against time integration where the joint slips hard:
  3 are 2.4-3.6 % off there, 5 up to 1.8 %), 64 samples per period, the whole set timed
  (the goal: under 10 s);
- unreduced HBM: every DOF, at ``CHECK`` of the same points (time per point, answer);
- time integration: Newmark on the same Craig-Bampton system (512 steps per period) from
  rest to the periodic steady state (tolerance 1e-6 of the range per period), at
  the mode-1 points of ``CHECK`` (mode 2 settles over hundreds of periods of 512 steps,
  hours in this integrator; time per point against the set's time per point: the
  goal >= 100x; harmonic-1 response against HBM with ``H_CHECK`` harmonics, 256 samples:
  the goal within 1 %; HBM with fewer harmonics truncates what the slipping joint puts
  into harmonics 5 and 7, printed as well).

Figures (ratios in this process): the set against its 10 s goal, the unreduced HBM and
time integration per point against the set's time per point; the set is timed as the
median of repeats (``--repeats``, default 3).
Run: ``python benchmarks/bench_structure_frf.py [--harmonics 7] [--repeats 3] [--smoke]``
(smoke: 4 points per mode, 3 harmonics, the first check point, Newmark to 1e-3).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.signal.frfset import FrfSet  # noqa: E402
from labjoint.structure import load_structure  # noqa: E402
from labjoint.structure.frf import system_of  # noqa: E402
from labjoint.structure.hbm import HarmonicBalance  # noqa: E402
from labjoint.structure.modal import with_parameter  # noqa: E402
from labjoint.structure.predict import FrfPredictor  # noqa: E402
from labjoint.structure.timeint import steady_state  # noqa: E402

SEED000 = ROOT / "configs" / "structure-seed000.toml"
LAW = {"richard_abbott.ke": 1e10, "richard_abbott.kp": 1e8, "richard_abbott.F_y": 3e3,
       "richard_abbott.n": 2.0}
LEVELS = (2.0, 10.0, 30.0)
POINTS = 34
CHECK = ((0, 0.97, 10.0), (0, 1.0, 30.0), (1, 0.99, 30.0))   # (mode, f / f_n, level)
H = H_SET = 7
H_CHECK = 7


def structure():
    s = load_structure(SEED000)
    for k, v in LAW.items():
        s = with_parameter(s, k, v)
    return s


def frf_set(freqs: np.ndarray, H: int = H, levels=LEVELS) -> FrfSet:
    f = np.concatenate([freqs] * len(levels))
    lv = np.repeat(levels, freqs.size)
    one = np.ones((f.size, 1, H), complex)
    return FrfSet(f, lv, ["up"] * f.size, lv.astype(complex), ("free_end",), one, 0 * one.real)


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--harmonics", type=int, default=H_SET,
                    help=f"harmonics of the FRF set (default {H_SET})")
    args = ap.parse_args()
    bench = Bench.from_args("structure_frf", args, repeats=3)
    H, points, checks, newmark_tol, steps, h_check, n_check = (
        args.harmonics, POINTS, CHECK, 1e-6, 512, H_CHECK, 256)
    if args.smoke:
        H, points, checks, newmark_tol, steps, h_check, n_check = 3, 4, CHECK[:1], 1e-2, 64, 3, 64
    s = structure()
    t0 = time.perf_counter()
    pr = FrfPredictor(s, modes=10, harmonics=H, samples=max(64, 8 * H))
    nat = pr.natural_frequencies(2)
    t_setup = time.perf_counter() - t0
    freqs = np.concatenate([np.linspace(0.9 * fn, 1.05 * fn, points) for fn in nat])
    fs = frf_set(freqs, H)
    bench.warm_up(lambda: pr.predict(frf_set(freqs[:2], H, LEVELS[:1]), warm=False),
                  "2 points of the set")
    t = bench.repeat(lambda: pr.predict(fs, warm=False))
    resp, t_cb = t.result, t.median
    per_cb = t_cb / len(fs)
    bench.figure("CB + HBM FRF set / 10 s goal", (t_cb + t_setup) / 10.0,
                 "the 10 s goal (set + reduction)", value=t_cb, unit="s (set, median)",
                 target="<= 1", points=len(fs), harmonics=H, reduction_s=t_setup, timing=t)
    print(f"seed 000 assembly, joint {LAW}; modes {nat[0]:.2f} / {nat[1]:.2f} Hz (joints stuck)")
    print(f"CB (10 modes, {pr.system.n} DOF) + HBM ({H} harmonics): {len(fs)} points "
          f"({points} x 2 modes x {len(LEVELS)} levels) in {t_cb:.2f} s ({1e3 * per_cb:.1f} ms/point; "
          f"reduction {t_setup:.2f} s once); set under 10 s: {'yes' if t_cb + t_setup < 10 else 'NO'}")
    for (lv, _), idx in fs.groups():
        for m in range(2):
            band = idx[m * points:(m + 1) * points]
            a = np.abs(resp[band, 0, 0]) / lv
            k = int(np.argmax(a))
            print(f"  {lv:4.0f} N mode {m + 1}: peak {a[k]:.3g} m/s^2/N at {fs.frequencies_hz[band][k]:.2f} Hz, "
                  f"harmonic 3 up to {np.max(np.abs(resp[band, 0, 2])):.3g} m/s^2")
    full = system_of(s, None)
    cb = pr.system
    row = list(cb.output_names).index("free_end")
    for m, ratio, lv in checks:
        f = ratio * nat[m]
        w = 2 * np.pi * f
        p_hb, t_hb = {}, {}
        for key, h, n in (("set", H, max(64, 8 * H)), ("check", h_check, n_check)):
            hb = HarmonicBalance(cb, h, n)
            t0 = time.perf_counter()
            x = None
            for fk in np.linspace(0.9 * nat[m], f, 8):        # reach the point along its sweep
                x = hb.solve(2 * np.pi * fk, lv, x0=x, tol=pr.tol)
            t_hb[key] = (time.perf_counter() - t0) / 8
            p_hb[key] = hb.phasors(x)[1, row]
        hf = HarmonicBalance(full, H, max(64, 8 * H))
        t0 = time.perf_counter()
        xf = hf.solve(w, lv, x0=None, tol=pr.tol)
        t_full = time.perf_counter() - t0
        p_full = hf.phasors(xf)[1, row]
        d = lambda a, b: 100 * abs(a / b - 1)  # noqa: E731
        print(f"  mode {m + 1}, {f:.2f} Hz, {lv:g} N: CB+HBM {1e3 * t_hb['set']:.1f} ms/point "
              f"({H} harmonics; {h_check} with {n_check} samples: {1e3 * t_hb['check']:.0f} ms, differs "
              f"{d(p_hb['set'], p_hb['check']):.2f} %); unreduced HBM ({full.n} DOF) {t_full:.2f} s "
              f"({t_full / t_hb['set']:.0f}x), differs {d(p_full, p_hb['set']):.3f} %")
        bench.figure(f"unreduced HBM / CB + HBM, mode {m + 1} at {lv:g} N", t_full / t_hb["set"],
                     "the CB + HBM time per point (how many times slower)", value=t_full,
                     unit="s (unreduced)", differs_pct=d(p_full, p_hb["set"]))
        if m > 0:       # mode 2 settles over hundreds of periods: hours of Newmark steps
            continue
        t0 = time.perf_counter()
        ss = steady_state(cb, lv, f, h_check, steps_per_period=steps, tol=newmark_tol,
                          max_periods=4000)
        t_ti = time.perf_counter() - t0
        p_ti = ss.phasors[1, row]
        print(f"    time integration ({ss.periods} periods, {steps} steps each) {t_ti:.1f} s "
              f"({t_ti / per_cb:.0f}x the set's time per point), differs {d(p_ti, p_hb['check']):.3f} % "
              f"from {h_check} harmonics ({n_check} samples), {d(p_ti, p_hb['set']):.2f} % from the set's {H}")
        bench.figure(f"Newmark to steady state / CB + HBM per point, mode {m + 1} at {lv:g} N",
                     t_ti / per_cb, "the set's time per point (how many times slower)",
                     value=t_ti, unit="s (Newmark)", target=">= 100",
                     differs_pct=d(p_ti, p_hb["check"]))
    bench.finish(harmonics=H, points_per_mode=points)


if __name__ == "__main__":
    main()
