"""Benchmark: the structure view's dense model FRF curves (issue 32 item 7) against the
comparison's own prediction at the measured steps (one run, this shared 2-core machine).

Seed 000's assembly with the joint law its structure file ships
(configs/structure-seed000.toml), an FRF set of ``STEPS`` steps around mode 1 (0.97-1.03
x the linear natural frequency) at 2, 8 and 16.5 N made from the model itself, 3
harmonics. Timed, alternating (median of ``--repeats``, default 3):

- the curves: :func:`labjoint.compare.frf_curves.dense_curves`, ``POINTS`` frequencies
  per sweep over the steps and 25 % of their span around them (what POST
  /structures/{name}/curves runs as a job), the reduced model cached as in a diagnosis;
- the steps: the same law predicted at the measured steps by the comparison's
  predictor (:meth:`FrfPredictor.predict`, cold: each step from the previous one).

Figures: time per dense point over time per step (a dense point starts from a close
neighbour, so it should cost no more than a step), and the whole curves call against a
10 s goal (a job the page waits seconds for).
Run: ``python benchmarks/bench_structure_curves.py [--repeats 3] [--smoke]`` (smoke: 20
points per sweep, one repeat).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.harness import Bench, Timing, parser  # noqa: E402
from labjoint.compare.frf_api import load_frf  # noqa: E402
from labjoint.compare.frf_curves import dense_curves  # noqa: E402
from labjoint.structure import load_structure  # noqa: E402
from labjoint.structure.predict import FrfPredictor, synthetic_frfset  # noqa: E402

SEED000 = ROOT / "configs" / "structure-seed000.toml"
LEVELS = (2.0, 8.0, 16.5)
STEPS = 8
POINTS = 200


def main() -> None:
    args = parser(__doc__).parse_args()
    bench = Bench.from_args("structure_curves", args, repeats=3)
    points, repeats = (20, 1) if args.smoke else (POINTS, bench.repeats)
    s = load_structure(SEED000)
    law = s.joints[0].law
    pr = FrfPredictor(s, modes=10, harmonics=3)
    f1 = pr.natural_frequencies(1)[0]
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "set.json"
        synthetic_frfset(pr, None, np.linspace(0.97 * f1, 1.03 * f1, STEPS), LEVELS, harmonics=3,
                         noise=0.005, seed=1).save(path)
        opts = {"structure": str(SEED000), "modes": 10}
        model, params = law.model.expr, law.params
        ms, _ = load_frf([str(path)], None, opts)
        bench.warm_up(lambda: dense_curves([str(path)], model, params, opts, points=20), "20 points per sweep")
        dense = Timing([], [])
        steps = Timing([], [])
        for _ in range(repeats):                        # alternating: both see the same load
            for t, fn in ((dense, lambda: dense_curves([str(path)], model, params, opts, points=points)),
                          (steps, lambda: [m.predictor.predict(m.frfset, law, warm=False) for m in ms])):
                c0, t0 = time.process_time(), time.perf_counter()
                t.results.append(fn())
                t.wall.append(time.perf_counter() - t0)
                t.cpu.append(time.process_time() - c0)
    n_dense = sum(sw["model"]["points"] for sw in dense.result["sweeps"])
    n_steps = sum(len(m.frfset) for m in ms)
    per_dense, per_step = dense.median / n_dense, steps.median / n_steps
    print(f"seed 000 assembly, joint law {model} of the file; mode 1 {f1:.2f} Hz (joints stuck); "
          f"{len(ms)} sweeps: {n_dense} dense points in {dense.median:.2f} s ({1e3 * per_dense:.1f} ms/point), "
          f"{n_steps} steps in {steps.median:.3f} s ({1e3 * per_step:.1f} ms/step)")
    bench.figure("dense curve / prediction at the steps, per point", per_dense / per_step,
                 "the comparison's time per measured step (same law, same reduced model)",
                 value=1e3 * per_dense, unit="ms per dense point", target="<= 1", timing=dense,
                 dense_points=n_dense, steps=n_steps)
    bench.figure("curves of the set / 10 s goal", dense.median / 10.0, "the 10 s goal (a job the page waits for)",
                 value=dense.median, unit="s", target="<= 1", points_per_sweep=points, sweeps=len(ms))
    bench.finish(points_per_sweep=points, levels=list(LEVELS), steps_per_sweep=STEPS)


if __name__ == "__main__":
    main()
