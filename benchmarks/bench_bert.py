"""The model loop on the UNESP-BERT bolted beam through the CLI (issue 29 item 8).

    python benchmarks/bench_bert.py [--json] [--smoke] [--work DIR]

Import (configs/maps/bert.toml) -> ``labjoint modes`` of the 0.25 V random test ->
``labjoint ladder --modal`` on the sine tests and the 0.25 V random test (the data) ->
``labjoint fit --modal --out`` of the ladder's model and of the linear model ->
``labjoint predict`` of both on the 0.30 V random test, which no fit sees.

Figures (the same method for measured and model): mode-1 natural frequency of the laser
velocity per volt on the 0.30 V test (labjoint's broadband FRF and LSCF, as `labjoint
modes` does); response NRMSE of the laser velocity over the
whole 0.30 V record; velocity harmonic ratios |h_n| / |h_1| at 9.5 Hz (n = 2) and at 6 and
6.5 Hz (n = 3), least squares of harmonics 0..5 of the drive's frequency on the judged
window of each sine. ``--smoke``: one sine test and the random test, one ladder step
over two candidates, few iterations; no figures asserted. The 0.30 V test is never fitted.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = Path("/work/shared/data/bert/bert.h5")
CANDIDATES = "quadratic_stiffness,bilinear_stiffness,cubic_stiffness,coulomb"


def cli(*args: str) -> dict:
    exe = Path(sys.executable).with_name("labjoint")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    p = subprocess.run([str(exe), *args, "--json"], capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise SystemExit(f"labjoint {args[0]} failed: {p.stderr.strip()}")
    return json.loads(p.stdout)


def peak_hz(drive: np.ndarray, resp: np.ndarray, fs: float) -> float:
    """Mode 1 of the velocity per volt by labjoint's own path (`labjoint modes`: the
    broadband FRF estimator, its burst method here, then LSCF/LSFD in 5-40 Hz)."""
    from labjoint.identify.modes import find_modes
    from labjoint.signal.broadband import estimate

    frf = estimate(drive, resp[None, :], fs)
    modes = find_modes(frf.freq_hz, frf.h, "velocity", ["laser"], (5.0, 40.0))
    return float(min(modes, key=lambda m: abs(m["frequency_hz"] - 18.7))["frequency_hz"])


def harmonic_ratio(y: np.ndarray, f: float, fs: float, order: int) -> float:
    t = np.arange(y.size) / fs
    cols = [np.ones_like(t)]
    for h in range(1, 6):
        cols += [np.cos(2 * np.pi * h * f * t), np.sin(2 * np.pi * h * f * t)]
    c = np.linalg.lstsq(np.column_stack(cols), y, rcond=None)[0]
    amp = lambda h: float(np.hypot(c[2 * h - 1], c[2 * h]))  # noqa: E731
    return amp(order) / amp(1)


def run(work: Path, smoke: bool) -> dict:
    from labjoint.storage.reader import read_channels

    t0 = time.perf_counter()
    runs = work / "runs"
    if not (runs / "Rand_Rand0p30.h5").exists():
        cli("import", str(DATA), "--map", str(ROOT / "configs/maps/bert.toml"), "--out", str(runs))
    modes = cli("modes", str(runs / "Rand_Rand0p25.h5"), "--band", "5:120")
    (work / "modes.json").write_text(json.dumps(modes))
    sines = sorted(str(p) for p in runs.glob("Sine_Sine_*.h5"))
    if smoke:
        sines = [s for s in sines if "09p5Hz" in s]
    data = [*sines, str(runs / "Rand_Rand0p25.h5")]
    common = ["--modal", str(work / "modes.json"), "--responses", "laser", "--quiet"]
    lad = cli("ladder", *data, *common, "--model", "linear_stiffness+viscous", "--no-save",
              "--max-steps", "1" if smoke else "2",
              "--candidates", "quadratic_stiffness,cubic_stiffness" if smoke else CANDIDATES)
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
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--smoke", action="store_true")
    ap.add_argument("--work", default=None, help="working directory (default: a temporary one)")
    a = ap.parse_args()
    if a.work:
        Path(a.work).mkdir(parents=True, exist_ok=True)
        res = run(Path(a.work), a.smoke)
    else:
        with tempfile.TemporaryDirectory() as d:
            res = run(Path(d), a.smoke)
    if a.json:
        print(json.dumps(res))
    else:
        for k, v in res.items():
            print(f"{k}: {v}")


if __name__ == "__main__":
    main()
