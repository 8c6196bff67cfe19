"""Run the REST service on uvicorn: ``labjoint serve`` calls :func:`serve`.

Embedded default: the acquisition daemon runs in this process (on the simulated rig
unless the config says otherwise) and the API submits plans to its queue. With
``daemon=False`` the API only attaches to the job queue of a daemon running elsewhere
(``labjoint daemon``, services/labjoint-daemon.service) over the same data directory.
"""

from __future__ import annotations

import functools
import ipaddress
import logging
import os
import secrets
import socket
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import uvicorn

from labjoint.acquisition.admission import check_plan
from labjoint.api.app import create_app
from labjoint.api.settings import ENV_CONTROL, ApiSettings, load_settings
from labjoint.config import DEFAULT_CONFIG, RigConfig, parse_config
from labjoint.daemon import Daemon, JobQueue
from labjoint.errors import ConfigError
from labjoint.tomlfile import read_toml

log = logging.getLogger(__name__)
QUEUE_FILE = "queue.sqlite"


def load_rig_config(path: str | Path | None) -> RigConfig:
    """The rig config, its ``[api]`` table set aside (the API validates that itself)."""
    p = Path(path) if path is not None else DEFAULT_CONFIG
    data = read_toml(p, ConfigError, "config file")
    data.pop("api", None)
    data["source"] = str(p)
    return parse_config(data, source=str(p))


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and 'localhost'."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass
class Service:
    """A built service: the uvicorn server, the app, and the daemon it owns (if any)."""

    server: uvicorn.Server
    app: Any
    settings: ApiSettings
    daemon: Any = None
    queue: Any = None
    generated_token: str | None = None
    daemon_thread: threading.Thread | None = field(default=None, repr=False)
    _thread: threading.Thread | None = field(default=None, repr=False)

    def stop_daemon(self) -> None:
        """Stop the embedded daemon (output off, run files closed) and wait for it."""
        if self.daemon is not None:
            self.daemon.stop("the REST service stopped")
            if self.daemon_thread is not None:
                self.daemon_thread.join(30.0)

    def run(self, sock: socket.socket | None = None) -> None:
        """Serve until stopped (SIGINT/SIGTERM or :meth:`stop`). The daemon is stopped
        in the app's shutdown, before uvicorn re-raises a caught signal."""
        try:
            self.server.run(sockets=[sock] if sock is not None else None)
        finally:
            self.stop_daemon()

    def start_in_thread(self, sock: socket.socket) -> None:
        """Serve on the bound ``sock`` from a background thread (tests, notebooks)."""
        self._thread = threading.Thread(target=self.run, args=(sock,), daemon=True,
                                        name="labjoint-api")
        self._thread.start()

    def stop(self, timeout: float = 30.0) -> None:
        self.server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout)


def build(config_path: str | Path | None = None, host: str | None = None,
          port: int | None = None, daemon: bool = True, data_dir: str | Path | None = None,
          log_level: str = "info", env: dict[str, str] | None = None) -> Service:
    """Everything :func:`serve` runs, not yet started (the daemon is started)."""
    config = load_rig_config(config_path)
    ddir = Path(data_dir if data_dir is not None else config.rig.data_dir).resolve()
    settings = load_settings(ddir, config_path if config_path is not None else DEFAULT_CONFIG,
                             env=env, host=host, port=port,
                             catalog_url=config.rig.catalog_url or None)
    if not is_loopback(settings.host):
        log.warning("binding to %s: the API is reachable from the network", settings.host)
    generated = None
    if not settings.control_tokens:
        generated = secrets.token_urlsafe(24)
        settings = settings.model_copy(update={"control_tokens": (generated,)})
    queue = JobQueue(ddir / QUEUE_FILE, admit=functools.partial(check_plan, config=config))
    dmn = thread = None
    if daemon:
        dmn = Daemon(config, ddir, queue_db=ddir / QUEUE_FILE)
        thread = dmn.start_in_thread()
    try:
        app = create_app(settings, daemon=dmn, queue=queue, backend=config.rig.backend)
        uv = uvicorn.Config(app, host=settings.host, port=settings.port, log_level=log_level,
                            access_log=False, timeout_graceful_shutdown=10)
        svc = Service(uvicorn.Server(uv), app, settings, dmn, queue, generated, thread)
        app.state.shutdown_hooks.append(svc.stop_daemon)
        return svc
    except BaseException:
        if dmn is not None:
            dmn.stop("the REST service failed to start")
        raise


def serve(config_path: str | Path | None = None, host: str | None = None,
          port: int | None = None, daemon: bool = True, data_dir: str | Path | None = None,
          log_level: str = "info") -> None:
    """Run the REST service until interrupted (``labjoint serve``).

    Binds ``[api] host`` (default 127.0.0.1) unless ``host`` is given. Without any
    control token configured, one is generated for this session and printed on stderr.
    """
    svc = build(config_path, host, port, daemon, data_dir, log_level, env=dict(os.environ))
    if svc.generated_token is not None:
        sys.stderr.write(f"labjoint: no control token configured ({ENV_CONTROL} or [api] "
                         f"control_tokens); this session's control token: "
                         f"{svc.generated_token}\n")
    sys.stderr.write(f"labjoint: serving on http://{svc.settings.host}:{svc.settings.port} "
                     f"(daemon: {'embedded' if daemon else 'attached via the job queue'}, "
                     f"data: {svc.settings.data_dir})\n")
    svc.run()
