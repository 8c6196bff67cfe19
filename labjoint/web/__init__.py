"""The web dashboard: static ES modules served by :func:`labjoint.web.mount.mount_web`.

Runs, run pages (raw signals, loops, both identification methods), model comparison
(overlays, residual maps, missing-effect candidates, the ladder) and the live view of the
daemon, all drawn from the REST API under ``/api/v1``.
"""
