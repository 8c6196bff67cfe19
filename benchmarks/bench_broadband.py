"""Benchmark: fit and diagnose on 4 multisine records against the same on 4 sine records.

Both sets are recorded on the simulated rig (the default seed 002 joint) through the
real plans: 4 dwells at 400 Hz and 4 multisines (100-800 Hz, 10 Hz resolution) at the
same 4, 8, 12, 16 Vpp, 0.5 s each at 25.6 kS/s. The sine set is judged as steady cycles,
the multisine set as records along their history (equation error); the ratio of wall
times is the figure (median of repeats, alternating the two sets so that both see the same
load). Run: ``python -m benchmarks.bench_broadband [--repeats 3] [--smoke]`` (smoke: 2
levels, 0.3 s each, diagnose with two candidates).
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint import compare  # noqa: E402
from labjoint.acquisition.plans import dwell  # noqa: E402
from labjoint.acquisition.plans_waveform import multisine  # noqa: E402
from labjoint.acquisition.rig import open_rig  # noqa: E402
from labjoint.config import load_config  # noqa: E402
from labjoint.storage.writer import RunWriter  # noqa: E402

FS = 25600.0
LEVELS_VPP = (4.0, 8.0, 12.0, 16.0)
MODEL = "linear_stiffness+viscous"
SECONDS = 0.5


class _Clock:
    t = 0.0

    def __call__(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        self.t += dt


def record(plans: list, out: Path) -> list[str]:
    """Run the plans on the simulated rig; the run files written."""
    cfg = load_config(overrides={"daq": {"sample_rate_hz": FS, "block_samples": 2560}})
    writer, paths = RunWriter(out), []
    with open_rig(cfg) as rig:
        for plan in plans:
            clock = _Clock()
            result = rig.engine([writer], clock=clock, sleep=clock.sleep).run(plan)
            paths += [str(out / f"{r.name}.h5") for r in result.runs]
    return paths


def timed(fn, *args, **kw) -> tuple[float, dict]:
    t0 = time.perf_counter()
    res = fn(*args, **kw)
    return time.perf_counter() - t0, res


def main() -> int:
    args = parser(__doc__).parse_args()
    bench = Bench.from_args("broadband", args, repeats=3)
    levels, seconds, only = LEVELS_VPP, SECONDS, {}
    if args.smoke:
        levels, seconds, only = LEVELS_VPP[1:3], 0.3, {"candidates": ["cubic_stiffness", "coulomb"]}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        sines = record([dwell(400.0, v, n_cycles=int(400 * seconds)) for v in levels], out)
        ms = record([multisine(f_min_hz=100, f_max_hz=800, resolution_hz=10, amplitude_vpp=v,
                               n_periods=max(1, int(10 * seconds)), seed=i)
                     for i, v in enumerate(levels)], out)
        print(f"{len(sines)} sine and {len(ms)} multisine records, {seconds} s each at {FS:g} S/s")
        sets = (("sine", sines, "sine"), ("multisine", ms, "record"))
        bench.warm_up(lambda: [compare.fit(paths, MODEL, kind=kind) for _, paths, kind in sets],
                      "a fit of each set")
        times = {name: {"fit": [], "diagnose": []} for name, _, _ in sets}
        for _ in range(bench.repeats):
            for name, paths, kind in sets:
                t_fit, fit = timed(compare.fit, paths, MODEL, kind=kind)
                t_diag, diag = timed(compare.diagnose, paths, MODEL, kind=kind, **only)
                times[name]["fit"].append(t_fit)
                times[name]["diagnose"].append(t_diag)
                print(f"{name:9s}: fit {t_fit:6.2f} s (NRMSE {100 * fit['nrmse']:.2f} %), diagnose "
                      f"{t_diag:6.2f} s (best {diag['candidates'][0]['effect'] if diag['candidates'] else '-'})")
        for what in ("fit", "diagnose"):
            m, s = (statistics.median(times[n][what]) for n in ("multisine", "sine"))
            bench.figure(f"multisine {what} / sine {what}", m / s,
                         f"the same {what} on 4 sine records at the same levels", value=m,
                         unit="s (multisine)", target="<= 1")
    bench.finish(levels_vpp=list(levels), seconds=seconds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
