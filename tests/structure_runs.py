"""Step-sine plans run on the simulated structural rig (``configs/rig-structure-sim.toml``
unless a config is given), on a clock that advances only when the engine sleeps."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable

from labjoint.acquisition.engine import RunEngine
from labjoint.acquisition.rig import open_rig
from labjoint.config import CONFIG_DIR, RigConfig, load_config
from labjoint.storage.writer import RunWriter
from test_daemon_fixtures import FakeClock


def structure_config() -> RigConfig:
    return load_config(CONFIG_DIR / "rig-structure-sim.toml")


def run_plans(d: Path, plans: Iterable[tuple[Any, str]], cfg: RigConfig | None = None) -> list:
    """Each (plan, name prefix) in turn on one opened rig, run files into ``d``; the results."""
    cfg = cfg or structure_config()
    rig = open_rig(cfg)
    clock = FakeClock()
    try:
        eng = RunEngine(rig.generator, rig.daq, cfg.limits, [RunWriter(d)], clock=clock,
                        sleep=clock.sleep, rig=rig.sim, config=cfg)
        return [eng.run(plan, name_prefix=prefix) for plan, prefix in plans]
    finally:
        rig.close()
