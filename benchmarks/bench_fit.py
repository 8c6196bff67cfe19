"""Benchmark: fit linear_stiffness+iwan to 12 runs (3 frequencies x 4 amplitudes, 40 cycles
each, 25.6 kS/s) and print the wall time against the 5 s target and the recovered
parameters.

Synthetic data come from the closed-form steady Masing loop of the Segalman backbone
(not from the model's simulation code), plus 1 % force noise and 0.1 % displacement
noise. Run: ``python -m benchmarks.bench_fit`` (or ``python benchmarks/bench_fit.py``).
"""

from __future__ import annotations

import time

import numpy as np

from labjoint.models import ModelFitter, RunData

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


def make_runs(seed: int = 0) -> list[RunData]:
    """Runs whose force is k u + the Iwan force: virgin curve to the first peak, then the
    steady Masing loop F = -+g(U) +- 2 g((U +- u)/2)."""
    rng = np.random.default_rng(seed)
    iw = {k.split(".")[1]: v for k, v in TRUE.items() if k.startswith("iwan.")}
    runs = []
    for f in FREQS:
        for U in AMPS:
            n = int(round(FS / f * CYCLES))
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
    runs = make_runs()
    n = sum(len(r.force) for r in runs)
    ModelFitter("linear_stiffness+iwan", multistart=1, max_nfev=2).fit(runs[:1])  # JIT warm-up
    t0 = time.perf_counter()
    res = ModelFitter("linear_stiffness+iwan").fit(runs)
    wall = time.perf_counter() - t0
    print(f"fit linear_stiffness+iwan: {len(runs)} runs, {n} samples, {res.n_evals_} model "
          f"evaluations, {len(res.start_costs_)} starts")
    print(f"wall time {wall:.2f} s (target {TARGET_S:.0f} s, ratio {wall / TARGET_S:.2f}); "
          f"{n * res.n_evals_ / wall / 1e6:.1f} M samples/s")
    print(f"NRMSE {res.nrmse_:.4f}; success {res.success}")
    for k, v in TRUE.items():
        p = res.params_[k]
        print(f"  {k:22s} true {v:11.5g}  fit {p.value:11.5g} +- {p.stderr:.2g}")


if __name__ == "__main__":
    main()
