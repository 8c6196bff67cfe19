"""Stick-slip-boundary pipeline (seed 002 II.B): speed as a multiple of real time.

A 60 s, 50 kS/s record of the simulated rig (400 Hz, 20 Vpp, 5 Nm; joint with a
viscous part c = 1800 Ns/m so both methods see seed-002-like loops) is made in memory
(relative displacement and nanocomposite force in SI units), then timed (best of 3):

(a) the pipeline with K_t given: zero-phase low-pass of u (seed 002: 5th order, 3 kHz),
    rising quarter cycles, steady quarters, Eq. 6 for every sample (c_i), Eqs. 7-9;
(b) as (a) with K_t identified from the record's loop slope (low-pass of the force too);
(c) the Eqs. 6-9 kernel alone on the (a) quarters: samples solved per second.

Figure: record length / wall time ("x real time"); target >= 200x for (a).
Usage: ``.venv/bin/python benchmarks/bench_stickslip.py [--seconds 60]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

FS, F0, VPP, TORQUE, MU = 50_000.0, 400.0, 20.0, 5.0, 0.168


def record(seconds: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(u, F, fs) of a steady simulated run, SI units."""
    from labjoint.config import load_config
    from labjoint.hardware.interfaces import GeneratorSettings
    from labjoint.hardware.sim.config import SimConfig
    from labjoint.hardware.sim.rig import SimRig

    cfg = load_config()
    table = {**cfg.sim, "effects": [{"name": "viscous", "c": 1800.0}],
             "contact": {"torque_nm": TORQUE}}
    sc = SimConfig.from_rig(cfg.model_copy(update={"sim": table}))
    specs = cfg.daq.specs()
    rig = SimRig(sc, specs, FS)
    on = GeneratorSettings(F0, VPP, 0.0, True)
    rig.advance(int(0.5 * FS), on)
    v = rig.advance(int(seconds * FS), on)
    s = {c.name: v[i] * c.sensitivity for i, c in enumerate(specs)}
    return s["disp_1"] - s["disp_2"], s["shear_nc"], rig.sample_rate_hz


def best(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    from labjoint.identify.contact import ContactPressure
    from labjoint.identify.quarters import rising_quarters
    from labjoint.identify.stickslip import StickSlipIdentifier, stick_slip_curves
    from labjoint.signal.filter import lowpass

    t0 = time.perf_counter()
    u, F, fs = record(args.seconds)
    print(f"record: {args.seconds:g} s at {fs:g} S/s ({u.size} samples), simulated in "
          f"{time.perf_counter() - t0:.1f} s")
    md = {"torque_nm": TORQUE, "normal_force_n": TORQUE * 478.0}
    full = StickSlipIdentifier(MU).fit_arrays(u, F, fs, F0, metadata=md)   # warm-up
    kt = full.result_.shear_stiffness
    ta = best(lambda: StickSlipIdentifier(MU, kt).fit_arrays(u, None, fs, F0, metadata=md))
    tb = best(lambda: StickSlipIdentifier(MU).fit_arrays(u, F, fs, F0, metadata=md))
    q = rising_quarters(lowpass(u - u.mean(), fs), fs, F0)
    cp = ContactPressure(5e-3, TORQUE * 478.0)
    tc = best(lambda: stick_slip_curves(q.displacement_m, q.starts, shear_stiffness_n_per_m=kt.value,
                                        friction_coefficient=MU, contact=cp, frequency_hz=F0))
    s = full.result_.summary
    print(f"result: W = {s['energy_loss_j'] * 1e3:.4f} mJ, C = {s['damping_ns_per_m']:.1f} Ns/m, "
          f"{s['cycles']} steady quarters, K_t = {kt.value / 1e6:.3f} MN/m")
    print(f"(a) pipeline, K_t given:        {ta:.3f} s  -> {args.seconds / ta:.0f}x real time "
          f"(target >= 200x)")
    print(f"(b) pipeline, K_t from loop:    {tb:.3f} s  -> {args.seconds / tb:.0f}x real time")
    print(f"(c) Eqs. 6-9 kernel: {q.displacement_m.size} samples in {tc:.3f} s -> "
          f"{q.displacement_m.size / tc / 1e6:.1f} M samples/s, {args.seconds / tc:.0f}x real time")


if __name__ == "__main__":
    main()
