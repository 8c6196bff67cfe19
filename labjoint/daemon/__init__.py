"""The headless acquisition daemon and its persistent job queue.

The daemon owns the rig and runs queued plans (:class:`Daemon`); the CLI and the REST
service write to the queue (:class:`JobQueue`, SQLite in WAL mode) from any process.
"""

from labjoint.daemon.daemon import Daemon
from labjoint.daemon.setup import default_paths
from labjoint.daemon.lock import DaemonBusy
from labjoint.daemon.queue import JOB_STATUSES, Job, JobNotFound, JobQueue, JobStateError

__all__ = ["Daemon", "DaemonBusy", "JOB_STATUSES", "Job", "JobNotFound", "JobQueue",
           "JobStateError", "default_paths"]
