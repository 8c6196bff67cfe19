"""What the ``labjoint`` CLI (``daemon``, ``submit``, ``torque``...) calls.

Paths default as the daemon's do: data in the config's ``rig.data_dir``, the queue at
``<data_dir>/queue.sqlite``. ``config_path`` None means the simulated rig's config.
"""

from __future__ import annotations

import getpass
import logging
from pathlib import Path
from typing import Any

from labjoint.acquisition import plans
from labjoint.acquisition.admission import check_plan
from labjoint.acquisition.plans import load_plan
from labjoint.config import RigConfig, load_config
from labjoint.daemon.daemon import Daemon
from labjoint.daemon.setup import default_paths
from labjoint.daemon.queue import Job, JobQueue
from labjoint.errors import HardwareError, InputError

log = logging.getLogger(__name__)


def _config(config_path: str | Path | None) -> RigConfig:
    return load_config(config_path)


def open_queue(queue_db: str | Path | None = None, *, config_path: str | Path | None = None,
               data_dir: str | Path | None = None) -> JobQueue:
    """The job queue at ``queue_db``, or the one the config's daemon uses; plans are
    checked against the config's rig before they are queued."""
    if queue_db is None:
        _, queue_db, _ = default_paths(_config(config_path), data_dir)
    return JobQueue(queue_db, admit=lambda plan: check_plan(plan, _config(config_path)))


def run_daemon(config_path: str | Path | None = None, data_dir: str | Path | None = None, *,
               queue_db: str | Path | None = None, poll_s: float = 0.2) -> int:
    """Run the daemon in the foreground until SIGTERM/SIGINT; exit code 0 when stopped."""
    from labjoint.cli.output import TerminalLog

    root = logging.getLogger()
    if all(isinstance(h, TerminalLog) for h in root.handlers):   # only the CLI's own
        for h in list(root.handlers):
            root.removeHandler(h)
        handler = TerminalLog()
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        root.addHandler(handler)
        root.setLevel(logging.INFO)
    daemon = Daemon(_config(config_path), data_dir, queue_db, poll_s)
    daemon.run_forever()
    return 0


def read_plan_file(path: str | Path) -> dict[str, Any]:
    """The plan mapping in a TOML/JSON file, validated (errors name the file and field)."""
    p = Path(path)
    data = plans.read_plan_file(p)
    try:
        load_plan(data).close()  # validation, on the mapping read once
    except InputError as exc:
        raise InputError(exc.message, file=str(p), line=exc.line, field=exc.field) from None
    return dict(data)


def submit_plan(path: str | Path, queue_db: str | Path | None = None, *,
                config_path: str | Path | None = None, data_dir: str | Path | None = None,
                submitted_by: str | None = None) -> Job:
    """Queue the plan file at ``path``; the queued job."""
    plan = read_plan_file(path)
    q = open_queue(queue_db, config_path=config_path, data_dir=data_dir)
    try:
        job_id = q.submit(plan, submitted_by=submitted_by if submitted_by is not None else _user())
    except InputError as exc:
        raise InputError(exc.message, file=str(path), field=exc.field) from None
    return q.get(job_id)


def confirm_torque(job_id: str, torque_nm: float, queue_db: str | Path | None = None, *,
                   config_path: str | Path | None = None,
                   data_dir: str | Path | None = None) -> Job:
    """Tell the daemon the bolt is now at ``torque_nm`` so the waiting job continues."""
    return open_queue(queue_db, config_path=config_path, data_dir=data_dir).continue_torque(
        job_id, torque_nm)


def cancel_job(job_id: str, queue_db: str | Path | None = None, *,
               config_path: str | Path | None = None, data_dir: str | Path | None = None) -> Job:
    """Cancel a queued job, or ask the daemon to abort a running one."""
    return open_queue(queue_db, config_path=config_path, data_dir=data_dir).cancel(job_id)


def output_off(config_path: str | Path | None = None) -> dict[str, Any]:
    """Switch both generator outputs OFF from outside the daemon (systemd ExecStopPost,
    after a crash; the antiphase drive can use CH2) and read them back. The simulated generator lives inside the daemon process and died
    with it, so there is nothing to switch on the simulated rig."""
    config = _config(config_path)
    if config.rig.backend != "real":
        return {"backend": config.rig.backend, "output": None,
                "note": "simulated generator: nothing outside the daemon to switch off"}
    from labjoint.hardware.afg1022 import AFG1022

    gen = AFG1022.from_config(config.generator)
    try:
        gen.set_output(False)
        settings = gen.read_settings()
    finally:
        gen.close()
    if settings.output:
        raise HardwareError(f"{config.generator.resource}: output still reads ON after OFF")
    return {"backend": "real", "output": False, "channels_off": [1, 2],
            "resource": config.generator.resource}


def _user() -> str:
    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return ""
