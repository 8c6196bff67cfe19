"""Stick-slip-boundary pipeline (seed 002 II.B): speed as a multiple of real time.

A 60 s, 50 kS/s record of the simulated rig (400 Hz, 20 Vpp, 5 Nm; joint with a
viscous part c = 1800 Ns/m so both methods see seed-002-like loops) is made in memory
(relative displacement and nanocomposite force in SI units), then timed (best of 3):

(a) the pipeline with K_t given: zero-phase low-pass of u (seed 002: 5th order, 3 kHz),
    rising quarter cycles, steady quarters, Eq. 6 for every sample (c_i), Eqs. 7-9;
(b) as (a) with K_t identified from the record's loop slope (low-pass of the force too);
(c) the Eqs. 6-9 kernel alone on the (a) quarters: samples solved per second.

Figure: record length / median wall time ("x real time"); target >= 200x for (a).
Usage: ``.venv/bin/python benchmarks/bench_stickslip.py [--seconds 60] [--repeats 5] [--smoke]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402

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


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    if args.smoke:
        args.seconds = 0.5
    bench = Bench.from_args("stickslip", args, repeats=5)
    from labjoint.identify.contact import ContactPressure
    from labjoint.identify.quarters import rising_quarters
    from labjoint.identify.stickslip import StickSlipIdentifier, stick_slip_curves
    from labjoint.signal.filter import lowpass

    u, F, fs = record(args.seconds)
    print(f"record: {args.seconds:g} s at {fs:g} S/s ({u.size} samples)")
    md = {"torque_nm": TORQUE, "normal_force_n": TORQUE * 478.0}
    full = bench.warm_up(lambda: StickSlipIdentifier(MU).fit_arrays(u, F, fs, F0, metadata=md),
                         "the whole pipeline on the record")
    kt = full.result_.shear_stiffness
    ta = bench.repeat(lambda: StickSlipIdentifier(MU, kt).fit_arrays(u, None, fs, F0, metadata=md))
    tb = bench.repeat(lambda: StickSlipIdentifier(MU).fit_arrays(u, F, fs, F0, metadata=md))
    q = rising_quarters(lowpass(u - u.mean(), fs), fs, F0)
    cp = ContactPressure(5e-3, TORQUE * 478.0)
    tc = bench.repeat(lambda: stick_slip_curves(
        q.displacement_m, q.starts, shear_stiffness_n_per_m=kt.value, friction_coefficient=MU,
        contact=cp, frequency_hz=F0))
    s = full.result_.summary
    print(f"result: W = {s['energy_loss_j'] * 1e3:.4f} mJ, C = {s['damping_ns_per_m']:.1f} Ns/m, "
          f"{s['cycles']} steady quarters, K_t = {kt.value / 1e6:.3f} MN/m")
    bench.figure("(a) pipeline, K_t given", args.seconds / ta.median, "real time",
                 value=ta.median, unit="s", target=">= 200", timing=ta)
    bench.figure("(b) pipeline, K_t from the loop", args.seconds / tb.median, "real time",
                 value=tb.median, unit="s", timing=tb)
    bench.figure("(c) Eqs. 6-9 kernel alone", args.seconds / tc.median, "real time",
                 value=q.displacement_m.size / tc.median / 1e6, unit="M samples/s", timing=tc)
    bench.finish(seconds=args.seconds, energy_loss_j=s["energy_loss_j"])


if __name__ == "__main__":
    main()
