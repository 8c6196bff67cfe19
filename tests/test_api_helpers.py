"""Shared helpers for the API tests (no tests here): a live uvicorn server on loopback
and run files of a known linear joint written through the real RunWriter."""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import uvicorn

from labjoint.documents import Block, RunStart, RunStop
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage import Catalog
from labjoint.storage.writer import RunWriter
import patience

CONTROL = "control-token-0123"
READ = "read-token-4567"
AUTH = {"Authorization": f"Bearer {CONTROL}"}
READ_AUTH = {"Authorization": f"Bearer {READ}"}
DISP_M_PER_V = 1.25e-5   # capacitive sensors, 80 V/mm (seed 002)
NC_N_PER_V = 301.0       # nanocomposite shear sensor near 400 Hz (seed 002)
REF_N_PER_V = 50.0


def channels() -> list[ChannelSpec]:
    return [ChannelSpec("force_ref", "force", "force", "N", REF_N_PER_V),
            ChannelSpec("disp_1", "capacitive", "displacement", "m", DISP_M_PER_V),
            ChannelSpec("disp_2", "capacitive", "displacement", "m", DISP_M_PER_V),
            ChannelSpec("shear_nc", "nanocomposite", "force", "N", NC_N_PER_V)]


def linear_joint(n: int, fs: float, f: float, amp_m: float, k: float, c: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time, relative displacement U sin(wt) and force k u + c du/dt."""
    t = np.arange(n) / fs
    w = 2 * np.pi * f
    u = amp_m * np.sin(w * t)
    return t, u, k * u + c * amp_m * w * np.cos(w * t)


def write_linear_run(data_dir: Path, catalog: Catalog, name: str, *, fs: float = 20000.0,
                     f: float = 100.0, amp_m: float = 5e-6, k: float = 1e7, c: float = 500.0,
                     n: int = 8000, vpp: float = 5.0, torque_nm: float = 5.0,
                     status: str = "complete", plan: str = "amplitude_sweep") -> Path:
    """A run of the linear joint F = k u + c du/dt, in volts as the rig records it:
    disp_1 = +u/2 and disp_2 = -u/2, the joint force on the nanocomposite sensor."""
    _, u, F = linear_joint(n, fs, f, amp_m, k, c)
    volts = np.stack([F / REF_N_PER_V, 0.5 * u / DISP_M_PER_V, -0.5 * u / DISP_M_PER_V,
                      F / NC_N_PER_V])
    md = {"frequency_hz": f, "excitation_vpp": vpp, "torque_nm": torque_nm,
          "normal_force_n": 478.0 * torque_nm, "plan": plan, "plan_step": 0,
          "displacement_channels": ["disp_1", "disp_2"], "joint_force_channel": "shear_nc",
          "reference_force_channel": "force_ref"}
    w = RunWriter(data_dir, catalog=catalog)
    uid = f"uid-{name}"
    w("start", RunStart(uid, name, channels(), fs, md))
    for a in range(0, n, 4096):
        w("block", Block(uid, a, volts[:, a:a + 4096]))
    w("stop", RunStop(uid, status, n_samples=n))
    return data_dir / f"{name}.h5"


@contextlib.contextmanager
def live_server(app: Any) -> Iterator[str]:
    """Serve ``app`` with uvicorn on a free loopback port from a thread; the base URL."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="on")
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + patience.s(10)
    while not server.started:
        if time.monotonic() > deadline or not thread.is_alive():
            raise RuntimeError("uvicorn did not start")
        time.sleep(0.01)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(patience.s(10))
        sock.close()


def wait_for(get: Any, done: Any, timeout: float = 60.0, poll: float = 0.05) -> Any:
    """Poll ``get()`` until ``done(value)``; the value (AssertionError after ``timeout``
    seconds, scaled for a busy machine: :mod:`patience`)."""
    end = time.monotonic() + patience.s(timeout)
    while True:
        v = get()
        if done(v):
            return v
        assert time.monotonic() < end, f"timed out waiting; last value: {v}"
        time.sleep(poll)


def sim_config_file(tmp_path: Path, api: str = "") -> Path:
    """configs/rig-sim.toml at 10 kS/s in 0.1 s blocks (fast to simulate, >> 400 Hz),
    with an ``[api]`` table ``api`` appended."""
    from labjoint.config import CONFIG_DIR

    text = (CONFIG_DIR / "rig-sim.toml").read_text()
    for old, new in (("sample_rate_hz = 50000.0", "sample_rate_hz = 10000.0"),
                     ("block_samples = 5000", "block_samples = 1000"),
                     ('visa_library = "afg1022-sim.yaml@sim"',
                      f'visa_library = "{CONFIG_DIR / "afg1022-sim.yaml"}@sim"')):
        assert old in text, old
        text = text.replace(old, new)
    text = _with_api(text, api)
    p = tmp_path / "rig.toml"
    p.write_text(text)
    return p


def _with_api(text: str, api: str) -> str:
    """``text`` (a rig config) with the ``key = value`` lines of ``api`` set in its
    ``[api]`` table: replacing a key already there, else added (TOML forbids repeats)."""
    if not api.strip():
        return text
    if "\n[api]" not in text:
        return text + "\n[api]\n" + api
    head, tail = text.split("\n[api]\n", 1)
    nxt = tail.find("\n[")
    body, rest = (tail, "") if nxt < 0 else (tail[:nxt + 1], tail[nxt + 1:])
    lines = body.splitlines()
    for new in (ln for ln in api.splitlines() if "=" in ln):
        key = new.split("=", 1)[0].strip()
        at = [i for i, ln in enumerate(lines) if ln.split("=", 1)[0].strip() == key]
        if at:
            lines[at[0]] = new
        else:
            lines.insert(0, new)
    return head + "\n[api]\n" + "\n".join(lines) + "\n" + rest


#: Plan settings that keep simulated plans short.
SHORT = {"n_cycles": 20, "steady_max_cycles": 40, "steady_window": 5, "steady_tol": 0.05}


def write_sim_run(data_dir: Path, catalog: Catalog, name: str, *, frequency_hz: float = 400.0,
                  vpp: float = 8.0, torque_nm: float = 5.0, seconds: float = 0.25,
                  settle_s: float = 0.0, status: str = "complete", stop: bool = True) -> Any:
    """A run of the simulated rig (configs/rig-sim.toml, 50 kS/s) from rest, so its first
    cycles are the start transient, written through RunWriter as the engine writes it.
    ``stop=False`` leaves the run open (status "running"): the writer is returned, call
    ``writer("stop", RunStop(f"uid-{name}", ...))`` to finish it."""
    from labjoint.config import load_config
    from labjoint.hardware.interfaces import GeneratorSettings
    from labjoint.hardware.sim.config import SimConfig
    from labjoint.hardware.sim.rig import SimRig

    cfg = load_config()
    table = dict(cfg.sim)
    table["contact"] = {**table.get("contact", {}), "torque_nm": torque_nm}
    specs = cfg.daq.specs()
    fs = cfg.daq.sample_rate_hz
    rig = SimRig(SimConfig.from_rig(cfg.model_copy(update={"sim": table})), specs, fs)
    on = GeneratorSettings(frequency_hz, vpp, 0.0, True)
    if settle_s > 0:
        rig.advance(int(settle_s * fs), on)
    volts = rig.advance(int(seconds * fs), on)
    md = {"frequency_hz": frequency_hz, "excitation_vpp": vpp, "torque_nm": torque_nm,
          "normal_force_n": 478.0 * torque_nm, "plan": "dwell", "plan_step": 0,
          "displacement_channels": ["disp_1", "disp_2"], "joint_force_channel": "shear_nc",
          "reference_force_channel": "force_ref"}
    w = RunWriter(data_dir, catalog=catalog, flush_interval_s=0.0)
    uid = f"uid-{name}"
    w("start", RunStart(uid, name, specs, rig.sample_rate_hz, md))
    for a in range(0, volts.shape[1], 5000):
        w("block", Block(uid, a, volts[:, a:a + 5000]))
    if not stop:
        w.flush()
        return w
    w("stop", RunStop(uid, status, n_samples=volts.shape[1]))
    return data_dir / f"{name}.h5"
