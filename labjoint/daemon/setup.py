"""What the daemon sets up before it runs jobs: its paths, the rig, and the stored sensor
calibrations applied to the DAQ channels (re-read before every job)."""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path
from typing import Any

from labjoint.config import RigConfig
from labjoint.errors import HardwareError, InputError

log = logging.getLogger(__name__)


def open_rig_lazily(config: RigConfig) -> Any:
    """:func:`labjoint.acquisition.rig.open_rig`, imported when first needed (it loads
    the simulator or the instrument drivers)."""
    from labjoint.acquisition.rig import open_rig

    return open_rig(config)


def calibrated_config(config: RigConfig, data_dir: str | Path
                      ) -> tuple[RigConfig, dict[str, list[dict[str, Any]]]]:
    """``config`` with the calibrations stored in ``<data_dir>/calibrations.json`` applied.

    Each calibrated channel gets the store's whole (frequency_hz, N/V) table
    (:meth:`~labjoint.identify.calibration.CalibrationStore.apply`); the factor a run is
    read with is that table interpolated at the run's drive frequency (the generator's
    read-back ``frequency_hz`` in its metadata), by the reader and the engine's safety
    checks alike. Also returns, per channel, the provenance of every table point (N/V,
    uncertainty, calibration runs, store file) for the engine to record in each run's
    metadata. An unreadable store raises InputError naming it.
    """
    from labjoint.identify.calibration import CalibrationStore  # identify is below daemon

    store = CalibrationStore.open(Path(data_dir))
    specs = {s.name: s for s in store.apply(config.daq.specs()) if s.calibration}
    tables = {name: s.calibration for name, s in specs.items()}
    if not tables:
        return config, {}
    chans = [c.model_copy(update={
        "calibration": [tuple(p) for p in tables[c.name]],
        "calibration_phase": [tuple(p) for p in specs[c.name].calibration_phase]})
        if c.name in tables else c for c in config.daq.channels]
    cfg = config.model_copy(update={"daq": config.daq.model_copy(update={"channels": chans})})
    sources = {name: [{"frequency_hz": q.frequency_hz, "n_per_v": q.n_per_v,
                       "uncertainty": q.uncertainty, "phase_deg": q.phase_deg,
                       "phase_uncertainty_deg": (q.phase_uncertainty_deg if
                                                 math.isfinite(q.phase_uncertainty_deg) else None),
                       "runs": list(q.runs),
                       "created": q.created, "store": str(store.path.resolve())}
                      for q in store.channels[name]] for name in tables}
    return cfg, sources


def default_paths(config: RigConfig, data_dir: str | Path | None = None,
                  queue_db: str | Path | None = None) -> tuple[Path, Path, Path]:
    """(data dir, queue db, catalog db): ``config.rig.data_dir`` (relative to the working
    directory), ``<data_dir>/queue.sqlite`` and ``<data_dir>/catalog.sqlite`` (the catalog
    used unless the config's ``catalog_url`` names a PostgreSQL one)."""
    d = Path(data_dir) if data_dir is not None else Path(config.rig.data_dir)
    q = Path(queue_db) if queue_db is not None else d / "queue.sqlite"
    return d, q, d / "catalog.sqlite"


class Calibrations:
    """The stored calibrations as applied to the DAQ: ``sources`` (per channel, the
    provenance of every table point, recorded in each run) and the channel specs the
    DAQ was last configured with."""

    def __init__(self, config: RigConfig, data_dir: Path) -> None:
        self.config, self.data_dir = config, data_dir
        self.specs: list[Any] = []
        self.sources: dict[str, list[dict[str, Any]]] = {}

    def initial(self) -> RigConfig:
        """The config to open the rig with; an unreadable store is logged and left out
        (each job then retries it and fails with its message)."""
        try:
            cfg, self.sources = calibrated_config(self.config, self.data_dir)
        except InputError as exc:
            log.error("stored calibrations not applied: %s", exc)
            cfg, self.sources = self.config, {}
        self.specs = cfg.daq.specs()
        return cfg

    def refresh(self, daq: Any) -> None:
        """Re-read the store before a job; reconfigure the DAQ's channels (output off
        between jobs) only if the calibrated channels changed."""
        cfg, sources = calibrated_config(self.config, self.data_dir)
        specs = cfg.daq.specs()
        if specs != self.specs:
            daq.configure(specs, daq.sample_rate_hz)
            log.info("calibrations applied: %s", {n: len(v) for n, v in sources.items()})
            self.specs = specs
        self.sources = sources


class LeftOut:
    """Run files a catalog outage left out of the index (``files``: file -> why), indexed
    again by :meth:`retry` once the catalog answers (at most every ``retry_s``)."""

    def __init__(self, retry_s: float = 5.0) -> None:
        self.files: dict[Path, str] = {}
        self.retry_s = retry_s
        self._tried = -1e300

    def add(self, pending: dict[Path, str]) -> str:
        """Keep ``pending`` (a writer's failed updates); what the job says about them."""
        self.files.update(pending)
        return (f"the catalog could not index {len(pending)} run(s) "
                f"({next(iter(pending.values()))}); their files are complete and are "
                "indexed when it is back")

    def retry(self, catalog: Any) -> None:
        """Index the files left out; stops at the first failure (still unreachable)."""
        now = time.monotonic()
        if not self.files or catalog is None or now - self._tried < self.retry_s:
            return
        self._tried = now
        for p in list(self.files):
            try:
                catalog.add(p)
            except Exception:
                return
            del self.files[p]
            log.warning("catalog: indexed %s, left out by an outage", p.name)


def switch_output_off(gen: Any, why: str) -> str | None:
    """Switch the generator's output off and confirm it by read-back: None when it is off,
    else what failed (logged)."""
    try:
        gen.set_output(False)
        if gen.read_settings().output:
            raise HardwareError("the generator still reports its output ON")
    except Exception as exc:
        failed = f"output off failed ({why}): {type(exc).__name__}: {exc}"
        log.error(failed)
        return failed
    log.info("generator output OFF (%s)", why)
    return None
