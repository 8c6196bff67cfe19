"""The model loop on the UNESP-BERT bolted beam through the CLI (issue 29 item 8).

    python benchmarks/bench_bert.py [--json] [--smoke] [--work DIR] [--data BERT.h5] [--repeats N]

Import (configs/maps/bert.toml) -> ``labjoint modes`` of the 0.25 V random test ->
``labjoint ladder --modal`` on the sine tests and the 0.25 V random test (the data) ->
``labjoint fit --modal --out`` of the ladder's model and of the linear model ->
``labjoint predict`` of both on the 0.30 V random test, which no fit sees. Each command
goes through labjoint's CLI entry point (``labjoint.cli.main.main``: its argument parsing,
exit code and JSON on stdout), called in this process (``--subprocess``: one ``labjoint``
process per command, which re-imports scipy, numba and h5py every time).

Figures (the same method for measured and model): mode-1 natural frequency of the laser
velocity per volt on the 0.30 V test (labjoint's broadband FRF and LSCF, as `labjoint
modes` does); response NRMSE of the laser velocity over the
whole 0.30 V record; velocity harmonic ratios |h_n| / |h_1| at 9.5 Hz (n = 2) and at 6 and
6.5 Hz (n = 3), least squares of harmonics 0..5 of the drive's frequency on the judged
window of each sine. The 0.30 V test is never fitted.

On the shared harness (benchmarks/README.md) each figure is a ratio to its reference in the
same process: the model's mode-1 frequency and harmonic ratios to the measured ones, the
model's NRMSE to the linear model's, and the loop's wall time (median of ``--repeats``,
default 1: the loop is minutes) to the duration of the records it fits. The import is the
untimed warm-up. The data: ``--data``, else ``$LABJOINT_BERT_DATA``, else the first
``shared/data/bert/bert.h5`` above this file (/work/shared/data/bert, README there).
``--smoke``: the 9 and 9.5 Hz sines cut to their first 6 s (the data fitted: the 0.25 V
random test, 16 s, is the modes' reference only, so no fit simulates it), the 0.25 V
random test whole and the 0.30 V one cut to 8 s (the burst), written to the temporary
work directory (never into the project), one ladder step over one candidate; if
the data are absent, a small generator of its own (an SDOF mode at 18.7 Hz with quadratic
and cubic stiffness, in bert.h5's layout) stands in, and the output says so. No figure is
judged in smoke mode.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.harness import Bench, parser  # noqa: E402

#: the benchmark's data, outside the project (/work/shared/data, README there): the first
#: ``shared/data/bert/bert.h5`` above this file (a worktree sits deeper than main)
DATA = next((d / "shared" / "data" / "bert" / "bert.h5" for d in ROOT.parents
             if (d / "shared" / "data" / "bert" / "bert.h5").is_file()),
            ROOT.parent / "shared" / "data" / "bert" / "bert.h5")
SMOKE_TESTS = {"Sine_Sine_09Hz": 6.0, "Sine_Sine_09p5Hz": 6.0, "Rand_Rand0p25": None,
               "Rand_Rand0p30": 8.0}
FS_BERT = 1024.0
CANDIDATES = "quadratic_stiffness,bilinear_stiffness,cubic_stiffness,coulomb,iwan,saturating_stiffness"
MAX_STEPS = 3


#: run each command as its own ``labjoint`` process (``--subprocess``); by default the same
#: entry point, ``labjoint.cli.main.main(argv)`` (argument parsing, exit code, the one JSON
#: object on stdout), is called in this process, so the scientific stack is imported once
#: and not once per command (about 1.3 s of CPU each, 20-30 s of wall at load 12-15)
SUBPROCESS = False


def cli(*args: str) -> dict:
    t0 = time.perf_counter()
    if SUBPROCESS:
        exe = Path(sys.executable).with_name("labjoint")
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        p = subprocess.run([str(exe), *args, "--json"], capture_output=True, text=True, env=env)
        rc, out, err = p.returncode, p.stdout, p.stderr
    else:
        import contextlib
        import io

        from labjoint.cli.main import main as labjoint_main

        o, e = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
            rc = labjoint_main([*args, "--json"])
        out, err = o.getvalue(), e.getvalue()
    print(f"  labjoint {args[0]}: {time.perf_counter() - t0:.1f} s", flush=True)
    if rc != 0:
        raise SystemExit(f"labjoint {args[0]} failed: {err.strip()}")
    return json.loads(out)


def peak_hz(drive: np.ndarray, resp: np.ndarray, fs: float) -> float | None:
    """Mode 1 of the velocity per volt by labjoint's own path (`labjoint modes`: the
    broadband FRF estimator, its burst method here, then LSCF/LSFD in 5-40 Hz); None (a
    JSON null) when the response has no mode there (a model fitted far from resonance:
    the smoke run's two sines)."""
    from labjoint.errors import InputError
    from labjoint.identify.modes import find_modes
    from labjoint.signal.broadband import estimate

    frf = estimate(drive, resp[None, :], fs)
    try:
        modes = find_modes(frf.freq_hz, frf.h, "velocity", ["laser"], (5.0, 40.0))
    except InputError as e:
        print(f"bert: no mode 1 in the predicted response: {e}", file=sys.stderr)
        return None
    return float(min(modes, key=lambda m: abs(m["frequency_hz"] - 18.7))["frequency_hz"])


def harmonic_ratio(y: np.ndarray, f: float, fs: float, order: int) -> float:
    t = np.arange(y.size) / fs
    cols = [np.ones_like(t)]
    for h in range(1, 6):
        cols += [np.cos(2 * np.pi * h * f * t), np.sin(2 * np.pi * h * f * t)]
    c = np.linalg.lstsq(np.column_stack(cols), y, rcond=None)[0]
    amp = lambda h: float(np.hypot(c[2 * h - 1], c[2 * h]))  # noqa: E731
    return amp(order) / amp(1)


#: the 0.30 V residual's parts (issue 29 item 8's diagnosis): frequency bands around mode 1
#: (18.7 Hz) and mode 2 (97.4 Hz), the rest; in time, the drive's burst and the free decay
BANDS_HZ = {"mode1_12_30hz": (12.0, 30.0), "mode2_80_115hz": (80.0, 115.0)}


def residual_parts(measured: np.ndarray, model: np.ndarray, drive: np.ndarray, fs: float) -> dict:
    """The model-minus-measured residual split by frequency band (its DFT over the whole
    record: the bands' parts add in quadrature to the NRMSE) and by time (the burst up to the
    drive's last sample above a fifth of its peak, then the free decay: each part's rms over
    the whole record's measured rms, so they too add in quadrature), and each time part's
    own NRMSE (its residual over its own measured rms, mean removed)."""
    y = np.asarray(measured, float) - np.mean(measured)
    r = np.asarray(model, float) - np.mean(model) - y
    n, scale = y.size, float(np.sqrt(np.mean(y * y)))
    R = np.fft.rfft(r)
    f = np.fft.rfftfreq(n, 1.0 / fs)
    w = np.full(f.size, 2.0)
    w[0] = 1.0
    if n % 2 == 0:
        w[-1] = 1.0
    power = lambda m: float(np.sqrt(np.sum(w[m] * np.abs(R[m]) ** 2) / n ** 2) / scale)  # noqa: E731
    out = {k: power((f >= lo) & (f < hi)) for k, (lo, hi) in BANDS_HZ.items()}
    inside = np.zeros(f.size, bool)
    for lo, hi in BANDS_HZ.values():
        inside |= (f >= lo) & (f < hi)
    out["elsewhere"] = power(~inside)
    end = int(np.flatnonzero(np.abs(drive) > 0.2 * np.abs(drive).max())[-1]) + 1
    for key, sl in (("driven", slice(0, end)), ("free_decay", slice(end, n))):
        out[key] = float(np.sqrt(np.sum(r[sl] ** 2) / n) / scale)
        ys = y[sl] - y[sl].mean() if sl.stop - sl.start > 1 else np.zeros(0)
        # a record cut at the burst's end (--smoke) has no free decay: null
        out[f"{key}_own_nrmse"] = float(np.sqrt(np.mean(r[sl] ** 2) / np.mean(ys ** 2))) \
            if ys.size and np.any(ys) else None
    out["drive_end_s"] = end / fs
    return out


def _generated_test(drive: np.ndarray, seed: int) -> dict[str, np.ndarray]:
    """Columns of one test of the stand-in generator: an SDOF mode at 18.7 Hz (1 % damping)
    with quadratic and cubic stiffness, driven by the voltage, RK4 at 8 sub-steps per sample
    (drive held), the laser velocity and four accelerations (mode-shape factors) plus noise."""
    w, z, g, k2, k3 = 2 * np.pi * 18.7, 0.01, 2.0, 4e4, 4e7
    h = 1.0 / (8 * FS_BERT)
    acc = lambda x, v, u: g * u - 2 * z * w * v - w * w * x - k2 * x * x - k3 * x ** 3  # noqa: E731
    x = v = 0.0
    vel = np.empty(drive.size)
    for n, u in enumerate(drive):
        for _ in range(8):
            a1 = acc(x, v, u)
            a2 = acc(x + h / 2 * v, v + h / 2 * a1, u)
            a3 = acc(x + h / 2 * (v + h / 2 * a1), v + h / 2 * a2, u)
            a4 = acc(x + h * (v + h / 2 * a2), v + h * a3, u)
            x, v = (x + h * (v + h / 6 * (a1 + a2 + a3)), v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4))
        vel[n] = v
    rng = np.random.default_rng(seed)
    dv = np.gradient(vel, 1.0 / FS_BERT)
    cols = {"input_V": drive, "laser_m_per_s": vel + 1e-4 * np.abs(vel).max() * rng.normal(size=vel.size)}
    for k, c in enumerate((0.2, 0.45, 0.7, 0.95), start=1):
        cols[f"acc{k}_m_per_s2"] = c * dv + 1e-3 * np.abs(dv).max() * rng.normal(size=vel.size)
    return cols


def smoke_data(path: Path, source: Path) -> str:
    """The smoke run's small file in bert.h5's layout: the tests of SMOKE_TESTS cut from
    ``source`` if it exists, else generated (``_generated_test``). Returns what it holds."""
    import h5py

    with h5py.File(path, "w") as out:
        if source.is_file():
            with h5py.File(source, "r") as src:
                for name, keep in SMOKE_TESTS.items():
                    g_in, g = src[name], out.create_group(name)
                    n = int(keep * float(g_in.attrs["sample_rate_hz"])) if keep else None
                    for key, ds in g_in.items():
                        g[key] = ds[:n]
                    g.attrs.update(dict(g_in.attrs))
            return f"the real data ({source}), cut to {list(SMOKE_TESTS)}"
        rng = np.random.default_rng(0)
        for seed, (name, keep) in enumerate(SMOKE_TESTS.items()):
            t = np.arange(int((keep or 16.0) * FS_BERT)) / FS_BERT
            if name.startswith("Sine"):
                f = float(name.split("_")[-1].removesuffix("Hz").replace("p", "."))
                drive = 0.14 * np.sin(2 * np.pi * f * t)
            else:
                level = 0.25 if "0p25" in name else 0.30
                drive = level * rng.normal(size=t.size) * (t < 6.0)
            g = out.create_group(name)
            g["time_s"] = t
            for key, col in _generated_test(drive, seed).items():
                g[key] = col.astype(np.float32)
            g.attrs.update({"sample_rate_hz": FS_BERT, "torque_nm": 5.0,
                            "source": "bench_bert.py stand-in generator (the data were absent)"})
        return f"a stand-in generator (the data {source} were absent)"


def import_runs(work: Path, data: Path) -> None:
    """``labjoint import`` of the data (the warm-up: done once, untimed)."""
    runs = work / "runs"
    if not (runs / "Rand_Rand0p30.h5").exists():
        cli("import", str(data), "--map", str(ROOT / "configs/maps/bert.toml"), "--out", str(runs))


def run(work: Path, smoke: bool) -> dict:
    from labjoint.storage.reader import read_channels

    t0 = time.perf_counter()
    runs = work / "runs"
    modes = cli("modes", str(runs / "Rand_Rand0p25.h5"), "--band", "5:120")
    (work / "modes.json").write_text(json.dumps(modes))
    sines = sorted(str(p) for p in runs.glob("Sine_Sine_*.h5"))
    data = sines if smoke else [*sines, str(runs / "Rand_Rand0p25.h5")]
    common = ["--modal", str(work / "modes.json"), "--responses", "laser", "--quiet"]
    lad = cli("ladder", *data, *common, "--model", "linear_stiffness+viscous", "--no-save",
              "--max-steps", "1" if smoke else str(MAX_STEPS),
              "--candidates", "quadratic_stiffness" if smoke else CANDIDATES)
    final = lad["steps"][-1]["model"]
    named = [s["added"] for s in lad["steps"] if s["added"]]
    out = {"named": named, "model": final, "ladder": [
        {"model": s["model"], "nrmse": s["nrmse"], "nrmse_validation": s["nrmse_validation"]}
        for s in lad["steps"]], "noise_floor": lad["noise_floor"], "adequate": lad["adequate"],
        "stop_reason": lad.get("stop_reason")}
    preds = {}
    for tag, expr in (("model", final), ("linear", "linear_stiffness+viscous")):
        path = work / f"{tag}.json"
        cli("fit", *data, *common, "--model", expr, "--out", str(path))
        preds[tag] = cli("predict", str(path), str(runs / "Rand_Rand0p30.h5"), "--full")
    rec = read_channels(runs / "Rand_Rand0p30.h5")
    fs, drive = rec.sample_rate_hz, rec.channel("input_V").samples
    ms = {k: np.asarray(v["channels"]["laser"]["model"]) for k, v in preds.items()}
    meas = np.asarray(preds["model"]["channels"]["laser"]["measured"])
    out["mode1_peak_hz_measured_0p30"] = peak_hz(drive, meas, fs)
    out["mode1_peak_hz_predicted_0p30"] = peak_hz(drive, ms["model"], fs)
    out["mode1_peak_hz_linear_0p30"] = peak_hz(drive, ms["linear"], fs)
    out["nrmse_0p30"] = {k: v["channels"]["laser"]["nrmse"] for k, v in preds.items()}
    out["nrmse_0p30_parts"] = {k: residual_parts(meas, m, drive, fs) for k, m in ms.items()}
    harm = {}
    for key, name, order in (("h2_9p5", "09p5Hz", 2), ("h3_6", "06Hz", 3), ("h3_6p5", "06p5Hz", 3)):
        p = runs / f"Sine_Sine_{name}.h5"
        if smoke and name != "09p5Hz":
            continue
        pr = cli("predict", str(work / "model.json"), str(p), "--full")["channels"]["laser"]
        f = float(read_channels(p).metadata["frequency_hz"])
        harm[key] = {"measured": harmonic_ratio(np.asarray(pr["measured"]), f, fs, order),
                     "model": harmonic_ratio(np.asarray(pr["model"]), f, fs, order)}
    out["harmonics"] = harm
    out["seconds"] = time.perf_counter() - t0
    out["loadavg"] = Path("/proc/loadavg").read_text().split()[:3]
    return out


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--json", action="store_true", help="also print the results as one JSON line "
                    "(before the harness's JSON line, which stays last)")
    ap.add_argument("--work", default=None, help="working directory (default: a temporary one)")
    ap.add_argument("--data", default=None, help="bert.h5 (default: $LABJOINT_BERT_DATA, else "
                    "the first shared/data/bert/bert.h5 above this file)")
    ap.add_argument("--subprocess", action="store_true", help="run each labjoint command as its "
                    "own process (default: labjoint's CLI entry point called in this process)")
    ap.set_defaults(repeats=1)
    a = ap.parse_args()
    global SUBPROCESS
    SUBPROCESS = a.subprocess
    data = Path(a.data or os.environ.get("LABJOINT_BERT_DATA") or DATA)
    if not a.smoke and not data.is_file():
        raise SystemExit(f"bench_bert: the data {data} are absent (--data or $LABJOINT_BERT_DATA)")
    bench = Bench.from_args("bert", a, repeats=1)
    with tempfile.TemporaryDirectory() as d:
        work = Path(a.work) if a.work else Path(d)
        work.mkdir(parents=True, exist_ok=True)
        source = f"the data ({data})"
        if a.smoke:
            source = smoke_data(Path(d) / "bert_smoke.h5", data)
            data = Path(d) / "bert_smoke.h5"
            work = work / "smoke" if a.work else work
        print(f"bert: data from {source}", flush=True)
        bench.warm_up(lambda: import_runs(work, data), "labjoint import of the tests")
        timing = bench.repeat(lambda: run(work, a.smoke))
        from labjoint.storage.reader import read_channels

        fitted = [p for p in (work / "runs").glob("*.h5") if "0p30" not in p.name
                  and (not a.smoke or p.stem.startswith("Sine_"))]
        record_s = sum(read_channels(p).channel("input_V").samples.size
                       / read_channels(p).sample_rate_hz for p in fitted)
    res = timing.result
    res["seconds"] = timing.median
    if a.json:
        print(json.dumps(res))
    else:
        for k, v in res.items():
            print(f"{k}: {v}")
    _figures(bench, res, timing, record_s)
    bench.finish(data=source, named=res["named"], model=res["model"])


def _figures(bench: Bench, res: dict, timing, record_s: float) -> None:
    meas = res["mode1_peak_hz_measured_0p30"]
    ref = "the measured one (0.30 V test, never fitted; the same FRF + LSCF path)"
    for tag, key in (("ladder", "mode1_peak_hz_predicted_0p30"), ("linear", "mode1_peak_hz_linear_0p30")):
        if res[key] is not None and meas is not None:      # None: no mode 1 in 5-40 Hz
            bench.figure(f"mode-1 frequency, {tag} model / measured", res[key] / meas, ref,
                         value=res[key], unit="Hz", measured_hz=meas)
    nr = res["nrmse_0p30"]
    bench.figure("laser NRMSE on the 0.30 V test, ladder model / linear model", nr["model"] / nr["linear"],
                 "the linear model (linear_stiffness+viscous) fitted to the same data",
                 value=nr["model"], unit="(NRMSE)", linear=nr["linear"])
    for key, h in res["harmonics"].items():
        bench.figure(f"harmonic ratio {key}, model / measured", h["model"] / h["measured"],
                     "the measured harmonic ratio of the same sine", value=h["model"], unit="",
                     measured=h["measured"])
    bench.figure("model loop (modes, ladder, fits, predictions)", record_s / timing.median,
                 "real time (the fitted records' duration)", value=timing.median, unit="s",
                 timing=timing)


if __name__ == "__main__":
    main()
