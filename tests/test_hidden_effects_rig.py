"""Hidden-effect data sets made with the simulated rig through the real pipeline.

The rig config selects the physics simulator with a joint law and injected effects
(``[sim] joint`` / ``effects``); the RunEngine drives it (generator, ramps, wait for
steady state, records) and the storage RunWriter writes the run files, as a user's
plans would. Nothing here shapes the data to a model.

Set-up choices, stated:

- DAQ: NI 9234 (DC-capable) at 25.6 kS/s, every channel DC-coupled, so constant forces
  and slow creep (offset, asymmetric slip) reach the files; the default NI 9233 is
  AC-coupled and would remove them.
- Joint force channel: a flat (piezoelectric) shear-force sensor with 0.3 N rms noise,
  the nanocomposite sensor's noise level (``force_noise_n``), but without the
  nanocomposite's own dynamics (its piezoresistive shelf and 12 kHz layer resonance shift
  the force's phase by -0.8..+1.3 % between 200 and 600 Hz): sensor dynamics are not an
  effect of the joint vocabulary and would confound the joint effect under test.
- ``from_rest``: each run starts from a rig at rest (a fresh specimen), the drive switched
  on in one step and the record started at once, so the record holds the joint's whole
  history (needed for wear, whose state is the energy dissipated since the start).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from labjoint.acquisition.engine import RunEngine
from labjoint.acquisition.messages import Configure, Output, Ramp, Record, WaitSteady
from labjoint.acquisition.rig import open_rig
from labjoint.config import load_config
from labjoint.compare import evaluate, noise_floor, prepare_runs
from labjoint.models import Model
from labjoint.storage import RunWriter
from test_daemon_fixtures import FakeClock

FS = 25600.0
NOISE_N = 0.3
#: the micro-slip joint the non-hysteretic effects are injected on (Segalman Iwan)
MICRO_SLIP = {"family": "iwan", "F_S": 120.0, "K_T": 14e6, "chi": -0.5, "beta": 0.3}
#: the micro-slip joint as model parameters
MICRO_SLIP_PARAMS = {"iwan.F_S": 120.0, "iwan.K_T": 14e6, "iwan.chi": -0.5, "iwan.beta": 0.3}
#: drive levels (Vpp) per frequency keeping that joint in micro-slip (F <~ 0.7 F_S)
LEVELS = {300.0: [2.0, 4.5, 7.0], 400.0: [4.0, 9.0, 15.0], 600.0: [5.0, 11.0, 18.0]}


def channels() -> list[dict[str, Any]]:
    dc = {"coupling": "DC"}
    return [
        {"name": "force_ref", "sensor": "force", "quantity": "force", "unit": "N",
         "sensitivity": 50.0, "physical_channel": "ai0", **dc},
        {"name": "disp_1", "sensor": "capacitive", "quantity": "displacement", "unit": "m",
         "sensitivity": 1.25e-5, "physical_channel": "ai1", **dc},
        {"name": "disp_2", "sensor": "capacitive", "quantity": "displacement", "unit": "m",
         "sensitivity": 1.25e-5, "physical_channel": "ai2", **dc},
        {"name": "shear_nc", "sensor": "force", "quantity": "force", "unit": "N",
         "sensitivity": 50.0, "physical_channel": "ai3", **dc},
    ]


def rig_config(joint: Any, effects: list[dict[str, Any]], seed: int = 0,
               from_rest: bool = False):
    over = {"daq": {"module": "NI 9234", "sample_rate_hz": FS, "block_samples": 2560,
                    "channels": channels()},
            "generator": {"visa_library": ""},
            "limits": {"max_displacement_m": 1e-3, "max_force_n": 2000.0},
            "sim": {"seed": seed, "joint": joint, "effects": effects,
                    "sensors": {"force_noise_n": NOISE_N}}}
    if from_rest:
        over["limits"]["ramp_vpp_per_s"] = 1e6
    return load_config(overrides=over)


def acquire(out: str | Path, joint: Any = None, effects: list[dict[str, Any]] = (),
            levels: dict[float, list[float]] | None = None, cycles: int = 30, seed: int = 0,
            from_rest: bool = False, prefix: str = "r", seconds: float = 0.0) -> list[Path]:
    """Run amplitude sweeps at each frequency of ``levels`` and return the run files.

    Default: per frequency, output on, then for each level ramp, wait for steady state,
    record ``cycles`` cycles. ``from_rest``: every run on a rig reset to rest, drive on in
    one step, record at once (the start-up transient included) ``cycles`` cycles or
    ``seconds``, whichever is longer (the rig's modes ring for ~0.1 s after the start).
    """
    levels = levels or LEVELS
    cfg = rig_config(joint if joint is not None else MICRO_SLIP, list(effects), seed, from_rest)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    with open_rig(cfg) as rig, RunWriter(out) as writer:
        clock = FakeClock()
        engine = RunEngine(rig.generator, rig.daq, cfg.limits, [writer], clock=clock,
                           sleep=clock.sleep, rig=rig.sim, config=cfg,
                           ramp_step_s=1.0 / FS if from_rest else 0.05)
        for f, vpps in levels.items():
            if from_rest:
                for v in vpps:
                    rig.sim.reset()
                    n = max(cycles, int(round(seconds * f)))
                    plan = [Configure(f, v), Output(True),
                            Record(f"{prefix}{f:g}Hz_{v:g}Vpp", n_cycles=n), Output(False)]
                    res = engine.run(plan, name_prefix="")
                    paths += [out / f"{r.name}.h5" for r in res.runs]
                continue
            plan: list[Any] = [Configure(f, vpps[0]), Output(True)]
            for i, v in enumerate(vpps):
                if i:
                    plan.append(Ramp(v))
                plan.append(WaitSteady(max_cycles=200, tol=0.01, window=8))
                plan.append(Record(f"{prefix}{f:g}Hz_{v:g}Vpp", n_cycles=cycles))
            plan.append(Output(False))
            res = engine.run(plan, name_prefix="")
            assert res.status == "complete", res.reason
            paths += [out / f"{r.name}.h5" for r in res.runs]
    return paths


# ---- checks of the data themselves --------------------------------------------------------

@pytest.mark.parametrize("from_rest", [False, True])
def test_true_model_leaves_the_noise_floor_on_rig_data(tmp_path, from_rest):
    """Through the engine and the run files, the joint's own law with its true parameters
    leaves exactly the noise (0.3 N rms on the force), whichever way the runs were taken."""
    paths = acquire(tmp_path, levels={300.0: [2.0, 7.0], 600.0: [5.0, 18.0]},
                    from_rest=from_rest, cycles=30, seconds=0.25 if from_rest else 0.0)
    runs = prepare_runs(paths)
    nf = noise_floor(runs)
    assert all(r.force_std == pytest.approx(NOISE_N, rel=0.1) for r in nf.runs)
    ev = evaluate(Model.parse("iwan"), MICRO_SLIP_PARAMS, runs)
    assert ev.nrmse() == pytest.approx(nf.nrmse, rel=0.1)
    assert all(r.primed == (0 if from_rest else 5) for r in runs)
