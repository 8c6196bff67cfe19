"""Benchmark: fit linear_stiffness+iwan to 12 runs (3 frequencies x 4 amplitudes, 40 cycles
each, 25.6 kS/s) and print the wall time against the 5 s target and the recovered
parameters.

Synthetic data come from the closed-form steady Masing loop of the Segalman backbone
(not from the model's simulation code), plus 1 % force noise and 0.1 % displacement
noise. Figures: the fit's wall time (median of repeats) as a ratio to the recorded data's
duration (real time) and to the 5 s target.
Run: ``python -m benchmarks.bench_fit [--smoke] [--repeats N]`` (or ``python benchmarks/bench_fit.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.models import ModelFitter, RunData  # noqa: E402

FS = 25600.0
FREQS = (100.0, 200.0, 400.0)
AMPS = (2e-6, 5e-6, 12e-6, 30e-6)
CYCLES = 40
TRUE = {"linear_stiffness.k": 2e6, "iwan.F_S": 80.0, "iwan.K_T": 1.5e7, "iwan.chi": -0.4,
        "iwan.beta": 0.2}
TARGET_S = 5.0


def segalman_backbone(x: np.ndarray, F_S: float, K_T: float, chi: float, beta: float) -> np.ndarray:
    """Monotonic loading curve of the 4-parameter Iwan model (closed form)."""
    d = beta + (chi + 1) / (chi + 2)
    phi_max = F_S * (1 + beta) / (K_T * d)
    r = np.minimum(np.abs(x) / phi_max, 1.0)
    return np.sign(x) * F_S / d * ((1 + beta) * r - r ** (chi + 2) / (chi + 2))


def make_runs(seed: int = 0, freqs=FREQS, amps=AMPS, cycles=CYCLES) -> list[RunData]:
    """Runs whose force is k u + the Iwan force: virgin curve to the first peak, then the
    steady Masing loop F = -+g(U) +- 2 g((U +- u)/2)."""
    rng = np.random.default_rng(seed)
    iw = {k.split(".")[1]: v for k, v in TRUE.items() if k.startswith("iwan.")}
    runs = []
    for f in freqs:
        for U in amps:
            n = int(round(FS / f * cycles))
            t = np.arange(n) / FS
            ph = np.mod(2 * np.pi * f * t, 2 * np.pi)
            u = U * np.sin(ph)
            g = lambda x: segalman_backbone(x, **iw)  # noqa: E731
            down = (ph >= np.pi / 2) & (ph < 3 * np.pi / 2)
            F = np.where(down, g(U) - 2 * g((U - u) / 2), -g(U) + 2 * g((u + U) / 2))
            first = t < 0.25 / f
            F[first] = g(u[first])
            F += TRUE["linear_stiffness.k"] * u
            F += rng.normal(0, 0.01 * np.abs(F).max(), n)
            u_meas = u + rng.normal(0, 1e-3 * U, n)
            runs.append(RunData.from_arrays(u_meas, F, FS, frequency_hz=f, steady=(int(FS / f * 2), n),
                                            name=f"{f:.0f}Hz_{U * 1e6:.0f}um"))
    return runs


def main() -> None:
    ap = parser(__doc__)
    args = ap.parse_args()
    bench = Bench.from_args("fit", args, repeats=3)
    runs = make_runs(cycles=8) if args.smoke else make_runs()
    if args.smoke:
        runs = runs[::3]
    n = sum(len(r.force) for r in runs)
    duration = sum(len(r.force) for r in runs) / FS
    bench.warm_up(lambda: ModelFitter("linear_stiffness+iwan", multistart=1, max_nfev=2)
                  .fit(runs[:1]), "a 2-evaluation fit of one run")
    timing = bench.repeat(lambda: ModelFitter("linear_stiffness+iwan").fit(runs))
    res, wall = timing.result, timing.median
    print(f"fit linear_stiffness+iwan: {len(runs)} runs, {n} samples ({duration:.2f} s of "
          f"record), {res.n_evals_} model evaluations, {len(res.start_costs_)} starts")
    print(f"wall time median {wall:.2f} s (best {timing.best:.2f} s); "
          f"{n * res.n_evals_ / wall / 1e6:.1f} M samples/s")
    bench.figure("fit wall / target", wall / TARGET_S, f"the {TARGET_S:g} s target",
                 value=wall, unit="s", target="<= 1", timing=timing)
    bench.figure("fit", duration / wall, "real time (the fitted records' duration)")
    print(f"NRMSE {res.nrmse_:.4f}; success {res.success_}")
    for k, v in TRUE.items():
        p = res.params_[k]
        print(f"  {k:22s} true {v:11.5g}  fit {p.value:11.5g} +- {p.stderr:.2g}")
    bench.finish(runs=len(runs), samples=n, evaluations=res.n_evals_, nrmse=res.nrmse_)


if __name__ == "__main__":
    main()
