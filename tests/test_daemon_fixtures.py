"""Shared helpers for the daemon tests: a small, fast simulated rig and polling helpers."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Callable

from labjoint.config import CONFIG_DIR, RigConfig, load_config
from labjoint.daemon import Daemon
from labjoint.storage import open_run
import patience

FS = 10000.0        # NI 9233 rate 50 kS/s / 5: fast to simulate, >> 400 Hz
BLOCK = 1000        # 0.1 s blocks, as the rig's 5000 at 50 kS/s
SHORT = {"n_cycles": 20, "steady_max_cycles": 40, "steady_window": 5, "steady_tol": 0.05}


def sim_config(realtime: bool = False, **limits: float) -> RigConfig:
    """The simulated rig at 10 kS/s (optionally paced to real time), with ``limits``."""
    over: dict[str, Any] = {"daq": {"sample_rate_hz": FS, "block_samples": BLOCK}}
    if limits:
        over["limits"] = limits
    if realtime:
        over["sim"] = {"seed": 0, "realtime": True}
    return load_config(overrides=over)


def sim_config_file(tmp_path: Path, realtime: bool = True) -> Path:
    """A config file like configs/rig-sim.toml at 10 kS/s (real-time paced) in tmp_path."""
    text = (CONFIG_DIR / "rig-sim.toml").read_text()
    for old, new in (("sample_rate_hz = 50000.0", f"sample_rate_hz = {FS}"),
                     ("block_samples = 5000", f"block_samples = {BLOCK}"),
                     ('visa_library = "afg1022-sim.yaml@sim"',
                      f'visa_library = "{CONFIG_DIR / "afg1022-sim.yaml"}@sim"')):
        assert old in text, old
        text = text.replace(old, new)
    if realtime:
        text = text.replace("[sim]\n", "[sim]\nrealtime = true\n")
    p = tmp_path / "rig.toml"
    p.write_text(text)
    return p


class FakeClock:
    """Engine clock that advances only when the engine sleeps (ramps take no time)."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        self.t += dt


def make_daemon(tmp_path: Path, config: RigConfig | None = None, **kw: Any) -> Daemon:
    clock = FakeClock()
    kw.setdefault("poll_s", 0.05)
    return Daemon(config or sim_config(), tmp_path / "data", clock=clock, sleep=clock.sleep, **kw)


def samples_for(n_cycles: int, frequency_hz: float, fs: float = FS) -> int:
    """Samples the engine records for ``n_cycles`` at ``frequency_hz``."""
    return int(math.ceil(n_cycles * fs / frequency_hz))


def wait_for(predicate: Callable[[], Any], timeout: float = 30.0, what: str = "condition") -> Any:
    """Poll ``predicate`` until it returns something truthy; that value (``timeout`` is
    scaled for a busy machine: :mod:`patience`)."""
    end = time.monotonic() + patience.s(timeout)
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def live_samples(data_dir: Path) -> int:
    """Samples flushed so far in the one run file of ``data_dir`` (read with SWMR)."""
    files = sorted(Path(data_dir).glob("*.h5"))
    if not files:
        return 0
    with open_run(files[0]) as rf:
        return rf.n_samples
