"""The REST service (FastAPI on uvicorn): plans, runs, analyses, models, emergency stop.

``create_app(settings, daemon=None, queue=None)`` builds the application;
:func:`labjoint.api.server.serve` runs it, by default with the acquisition daemon in
the same process on the simulated rig.
"""

from labjoint.api.app import API_PREFIX, create_app, mount_web
from labjoint.api.settings import ApiSettings, load_settings

__all__ = ["API_PREFIX", "ApiSettings", "create_app", "load_settings", "mount_web"]
