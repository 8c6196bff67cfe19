"""Benchmark: fit and diagnose on 4 multisine records against the same on 4 sine records.

Both sets are recorded on the simulated rig (the default seed 002 joint) through the
real plans: 4 dwells at 400 Hz and 4 multisines (100-800 Hz, 10 Hz resolution) at the
same 4, 8, 12, 16 Vpp, 0.5 s each at 25.6 kS/s. The sine set is judged as steady cycles,
the multisine set as records along their history (equation error); the ratio of wall
times is the figure (one run, this machine). Run: ``python -m benchmarks.bench_broadband``.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from labjoint import compare
from labjoint.acquisition.plans import dwell
from labjoint.acquisition.plans_waveform import multisine
from labjoint.acquisition.rig import open_rig
from labjoint.config import load_config
from labjoint.storage.writer import RunWriter

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
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        sines = record([dwell(400.0, v, n_cycles=int(400 * SECONDS)) for v in LEVELS_VPP], out)
        ms = record([multisine(f_min_hz=100, f_max_hz=800, resolution_hz=10, amplitude_vpp=v,
                               n_periods=int(10 * SECONDS), seed=i)
                     for i, v in enumerate(LEVELS_VPP)], out)
        print(f"{len(sines)} sine and {len(ms)} multisine records, {SECONDS} s each at {FS:g} S/s")
        rows = {}
        for name, paths, kind in (("sine", sines, "sine"), ("multisine", ms, "record")):
            t_fit, fit = timed(compare.fit, paths, MODEL, kind=kind)
            t_diag, diag = timed(compare.diagnose, paths, MODEL, kind=kind)
            rows[name] = (t_fit, t_diag)
            print(f"{name:9s}: fit {t_fit:6.2f} s (NRMSE {100 * fit['nrmse']:.2f} %), diagnose "
                  f"{t_diag:6.2f} s (best {diag['candidates'][0]['effect'] if diag['candidates'] else '-'})")
        print(f"multisine / sine: fit {rows['multisine'][0] / rows['sine'][0]:.2f}x, diagnose "
              f"{rows['multisine'][1] / rows['sine'][1]:.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
