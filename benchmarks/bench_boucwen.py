"""The Bouc-Wen hysteresis benchmark (Noel and Schoukens, 2016) and forward-simulation speed.

1. Speed: :func:`labjoint.models.simulate.simulate` on a Bouc-Wen oscillator (the
   vocabulary's ``bouc_wen``) over the training set's 40,960 samples with 20 sub-steps
   per sample: RK4 sub-steps per second (goal >= 2e6), median of 5; reference: this
   script's own compiled RK4 generator of the benchmark system (item 3) on the same force
   and sub-steps (a hand-written single-law loop: the floor a general model can reach).
2. Identification from ``../shared/data/boucwen/train.h5`` alone, by simulation error
   (:func:`labjoint.compare.output_error.fit_simulation`, started from the equation-error
   fit: no published value is used): ``inertia+viscous+linear_stiffness`` and
   ``inertia+viscous+linear_stiffness+bouc_wen``; time, RMSE on the training set's last
   period.
3. Test signals made the way the benchmark describes, by this script's own generator of
   the benchmark system (its published parameters, the classical Bouc-Wen law
   z' = alpha y' - beta (gamma |y'| |z|^(nu-1) z + delta y' |z|^nu), RK4 at 20x the sample
   rate): a new random-phase multisine 5-150 Hz, RMS 50 N, one period of 8192 samples
   simulated to steady state, and a sine sweep 5-150 Hz over 8192 samples from rest. The
   identified models predict them; RMSE in m (the published figures on the official test
   multisine: about 1.9e-5 m for polynomial nonlinear state-space models, 4.5e-5 m for
   dynoNet; goal <= 3e-6 m).

4. The identified parameters against the generator's, with their standard errors: the
   vocabulary's ``bouc_wen`` is seed 001's classical law dz/du = k0 - |z|^n (alpha
   sgn(z du) + beta), so the benchmark's system is k0 = alpha_B, alpha = beta_B gamma_B,
   beta = beta_B delta_B, n = nu (only these products are identifiable).

Run: ``.venv/bin/python benchmarks/bench_boucwen.py [--repeats 5] [--smoke]`` (smoke: the
first 2,048 training samples, test signals of 1,024). The generator is written here
independently of labjoint's simulator (its own rates, in the benchmark's notation).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import h5py
import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.compare.kinds import prepare  # noqa: E402
from labjoint.compare.output_error import fit_simulation, predict_record  # noqa: E402
from labjoint.models.simulate import fine_force, simulate  # noqa: E402
from labjoint.storage import Run  # noqa: E402

#: the benchmark's training data, outside the project (/work/shared/data, README there): the
#: first ``shared/data/boucwen/train.h5`` above this file (a worktree sits deeper than main)
DATA = next((d / "shared" / "data" / "boucwen" / "train.h5" for d in Path(__file__).resolve().parents
             if (d / "shared" / "data" / "boucwen" / "train.h5").is_file()),
            Path(__file__).resolve().parents[2] / "shared" / "data" / "boucwen" / "train.h5")
FS = 750.0
#: the benchmark's published system (used only to generate test signals here)
M_L, C_L, K_L = 2.0, 10.0, 5e4
ALPHA, BETA, GAMMA, DELTA, NU = 5e4, 1e3, 0.8, -1.1, 1.0
#: the same system in the vocabulary's parameters (item 4 of the docstring)
TRUE = {"inertia.m": M_L, "viscous.c": C_L, "linear_stiffness.k": K_L, "bouc_wen.k0": ALPHA,
        "bouc_wen.alpha": BETA * GAMMA, "bouc_wen.beta": BETA * DELTA, "bouc_wen.n": NU}


@njit(cache=True)
def _bench_rates(f, y, v, z):  # pragma: no cover - numba
    dz = ALPHA * v - BETA * (GAMMA * abs(v) * abs(z) ** (NU - 1.0) * z + DELTA * v * abs(z) ** NU)
    return v, (f - C_L * v - K_L * y - z) / M_L, dz


@njit(cache=True)
def _bench_integrate(ff, h, s, state):  # pragma: no cover - numba
    n = (ff.size - 1) // (2 * s) + 1
    out = np.empty(n)
    y, v, z = state[0], state[1], state[2]
    out[0] = y
    for i in range(n - 1):
        for j in range(s):
            k = 2 * (i * s + j)
            a1 = _bench_rates(ff[k], y, v, z)
            a2 = _bench_rates(ff[k + 1], y + 0.5 * h * a1[0], v + 0.5 * h * a1[1], z + 0.5 * h * a1[2])
            a3 = _bench_rates(ff[k + 1], y + 0.5 * h * a2[0], v + 0.5 * h * a2[1], z + 0.5 * h * a2[2])
            a4 = _bench_rates(ff[k + 2], y + h * a3[0], v + h * a3[1], z + h * a3[2])
            y += h * (a1[0] + 2 * a2[0] + 2 * a3[0] + a4[0]) / 6
            v += h * (a1[1] + 2 * a2[1] + 2 * a3[1] + a4[1]) / 6
            z += h * (a1[2] + 2 * a2[2] + 2 * a3[2] + a4[2]) / 6
        out[i + 1] = y
    state[0], state[1], state[2] = y, v, z
    return out


def benchmark_system(force: np.ndarray, periodic: bool, substeps: int = 20) -> np.ndarray:
    """The benchmark system's displacement under ``force`` (from rest, or its periodic
    steady state, compared about the mean)."""
    h = 1.0 / (FS * substeps)
    state = np.zeros(3)
    if not periodic:
        return _bench_integrate(fine_force(force, substeps, False), h, substeps, state)
    ff = fine_force(force, substeps, True)
    for _ in range(20):
        y = _bench_integrate(ff, h, substeps, state)
    return y[:-1] - np.mean(y[:-1])


def test_signals(n: int = 8192) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(2016)
    f = np.fft.rfftfreq(n, 1 / FS)
    sel = (f >= 5) & (f <= 150)
    spec = np.zeros(f.size, complex)
    spec[sel] = np.exp(2j * np.pi * rng.random(sel.sum()))
    ms = np.fft.irfft(spec, n)
    t = np.arange(n) / FS
    T = n / FS
    sweep = np.sin(2 * np.pi * (5 * t + (150 - 5) * t ** 2 / (2 * T)))
    return {"multisine": ms * 50 / np.std(ms), "sweep": sweep * 50 / np.std(sweep)}


def main() -> int:
    args = parser(__doc__).parse_args()
    if not DATA.is_file() and not args.smoke:
        print(f"no benchmark data at {DATA}", file=sys.stderr)
        return 2
    bench = Bench.from_args("boucwen", args, repeats=5)
    if DATA.is_file():
        with h5py.File(DATA) as h5:
            g = h5["multisine"]
            u, y = g["u"][:, 0], g["y"][:, 0]
    else:     # smoke without the outside data: this script's generator makes a training set
        print(f"no benchmark data at {DATA}: smoke run on this script's own generator")
        u = test_signals(2048)["multisine"]
        y = benchmark_system(u, True)
    n_test, period = 8192, 8192
    if args.smoke:
        u, y, n_test, period = u[:2048], y[:2048], 1024, 1024
    params = {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4, "bouc_wen.k0": 5e4,
              "bouc_wen.alpha": 800.0, "bouc_wen.beta": -1100.0, "bouc_wen.n": 1.0}
    expr_bw = "inertia+viscous+linear_stiffness+bouc_wen"
    bench.warm_up(lambda: (simulate(expr_bw, params, u[:64], FS), benchmark_system(u[:64], False)),
                  "labjoint's simulate and the generator on 64 samples")
    t_sim = bench.repeat(lambda: simulate(expr_bw, params, u, FS))
    t_gen = bench.repeat(lambda: benchmark_system(u, False))
    med = t_sim.median
    print(f"forward simulation: {u.size} samples x 20 sub-steps in {med:.3f} s (median) = "
          f"{u.size * 20 / med:.3g} sub-steps/s (goal >= 2e6)")
    bench.figure("forward simulation (bouc_wen model)", u.size / FS / med, "real time",
                 value=u.size * 20 / med, unit="RK4 sub-steps/s", target=">= 2e6 sub-steps/s",
                 timing=t_sim)
    bench.figure("forward simulation / hand-written generator", med / t_gen.median,
                 "this script's compiled RK4 of the same system, same force and sub-steps",
                 value=t_gen.median, unit="s (generator)", timing=t_gen)
    train = Run("bw_train", np.arange(u.size) / FS, y, u, {"sample_rate_hz": FS})
    signals = test_signals(n_test)
    tests = {}
    for name, F in signals.items():
        periodic = name == "multisine"
        tests[name] = (Run(f"test_{name}", np.arange(F.size) / FS,
                           benchmark_system(F, periodic), F, {"sample_rate_hz": FS}), periodic)
    rmse = {}
    for expr in ("inertia+viscous+linear_stiffness", expr_bw):
        t0 = time.perf_counter()
        fit = fit_simulation([train], expr)
        dt = time.perf_counter() - t0
        p = fit.fit[0]
        last = slice(max(0, p.predicted.size - period), p.predicted.size)
        rmse_last = float(np.sqrt(np.mean((p.measured[last] - p.predicted[last]) ** 2)))
        print(f"\n{expr}: identified in {dt:.1f} s ({fit.n_evals} simulations); training RMSE "
              f"(last period) {rmse_last:.3g} m")
        for k, q in fit.params.items():
            true = TRUE[k]
            print(f"  {k} = {q.value:.6g} +- {fit.stderr[k]:.2g} (generator {true:g}: "
                  f"{(q.value - true) / fit.stderr[k]:+.1f} standard errors)")
        for name, (run, periodic) in tests.items():
            m = prepare([run], kind="record", warmup=0)[0]
            pred = predict_record(fit.model, fit.params, m, periodic=periodic)
            rmse[(expr, name)] = pred.rmse
            print(f"  test {name}: RMSE {pred.rmse:.3g} m (goal <= 3e-6 m)")
    for name in tests:
        bench.figure(f"test {name} RMSE, bouc_wen model / linear model",
                     rmse[(expr_bw, name)] / rmse[("inertia+viscous+linear_stiffness", name)],
                     "the linear model identified the same way", value=rmse[(expr_bw, name)],
                     unit="m", target="<= 3e-6 m")
    bench.finish(samples=int(u.size))
    return 0


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    raise SystemExit(main())
