"""The client's shared parts: where the service is, the job states, the errors a request
or a job raises, and the small helpers every group of methods uses."""

from __future__ import annotations

import math
from typing import Any

import httpx

from labjoint.errors import LabjointError

ENV_URL = "LABJOINT_API_URL"
ENV_TOKEN = "LABJOINT_API_TOKEN"
DEFAULT_URL = "http://127.0.0.1:8000"
PLAN_FINISHED = ("done", "failed", "cancelled", "aborted")
JOB_FINISHED = ("complete", "failed", "cancelled")
TABLE_COLUMNS = (("run", "run", 1.0), ("Vpp", "excitation_vpp", 1.0),
                 ("U (um)", "displacement_amplitude_m", 1e6),
                 ("F (N)", "force_amplitude_n", 1.0), ("W (mJ)", "energy_loss_j", 1e3),
                 ("C (Ns/m)", "damping_ns_per_m", 1.0),
                 ("K (MN/m)", "stiffness_n_per_m", 1e-6), ("cycles", "cycles", 1.0))


class ApiError(LabjointError):
    """The service refused or failed a request."""

    def __init__(self, status: int, code: str, message: str, details: Any = None) -> None:
        super().__init__(f"HTTP {status} {code}: {message}")
        self.status, self.code, self.message, self.details = status, code, message, details


class JobFailed(LabjointError):
    """A job ended without a result (failed or cancelled); ``job`` is its record."""

    def __init__(self, job: dict[str, Any]) -> None:
        err = job.get("error") or {}
        super().__init__(f"job {job['id']} {job['status']}: {err.get('message', '')}".rstrip(": "))
        self.job = job


def _params(**kw: Any) -> dict[str, Any]:
    return {k: v for k, v in kw.items() if v is not None and v != []}


def _fmt(value: Any, scale: float) -> str:
    if value is None:
        return "-"
    if isinstance(value, str):
        return value
    if isinstance(value, int) and scale == 1.0:
        return str(value)
    x = float(value) * scale
    return f"{x:.4g}" if math.isfinite(x) else "-"


def _error(r: httpx.Response) -> ApiError:
    try:
        err = r.json()["error"]
        return ApiError(r.status_code, err["code"], err["message"], err.get("details"))
    except (ValueError, KeyError, TypeError):
        return ApiError(r.status_code, "http_error", r.text[:200] or r.reason_phrase)
