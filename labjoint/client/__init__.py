"""A small Python client of the labjoint REST service, for lab scripts (httpx).

Submit an amplitude sweep on the rig, wait for it, analyse its runs and print the
results table::

    from labjoint.client import Client

    # URL and token from $LABJOINT_API_URL (default http://127.0.0.1:8000) and
    # $LABJOINT_API_TOKEN (a control token: submitting a plan moves the shakers)
    with Client() as lab:
        job = lab.submit_plan("amplitude_sweep", amplitudes_vpp=[1, 4, 8],
                              frequency_hz=400, torque_nm=5, n_cycles=50)
        job = lab.wait_plan(job["id"], timeout=600)
        analysis = lab.analyze(job["runs"])         # hysteresis loop, seed 002 Eq. 1
        print(lab.results_table(analysis))

Every method returns the service's JSON (dicts and lists, SI units). A failed request
raises :class:`ApiError` carrying the HTTP status, the error code and the message; a
job that ends without a result raises :class:`JobFailed`.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any, Iterable

import httpx

from labjoint.client.base import (DEFAULT_URL, ENV_TOKEN, ENV_URL, JOB_FINISHED, PLAN_FINISHED,
                                  TABLE_COLUMNS, ApiError, JobFailed, _error, _fmt, _params)
from labjoint.client.modal import ModalMixin
from labjoint.client.spectra import SpectraMixin
from labjoint.client.structures import StructuresMixin

class Client(StructuresMixin, SpectraMixin, ModalMixin):
    """The REST API at ``base_url`` (default ``$LABJOINT_API_URL`` or 127.0.0.1:8000).
    Structures and backbones come from :class:`~labjoint.client.structures.StructuresMixin`,
    FRFs, modes and distortion from :class:`~labjoint.client.spectra.SpectraMixin`, the
    modal kind from :class:`~labjoint.client.modal.ModalMixin`.

    ``token`` defaults to ``$LABJOINT_API_TOKEN``; reads work without one unless the
    server requires it.
    """

    def __init__(self, base_url: str | None = None, token: str | None = None,
                 timeout: float = 30.0, transport: httpx.BaseTransport | None = None) -> None:
        url = base_url or os.environ.get(ENV_URL) or DEFAULT_URL
        token = token if token is not None else os.environ.get(ENV_TOKEN)
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self._http = httpx.Client(base_url=url.rstrip("/") + "/api/v1", headers=headers,
                                  timeout=timeout, transport=transport)

    # -- plumbing ------------------------------------------------------------------
    def request(self, method: str, path: str, **kw: Any) -> Any:
        """One request; the decoded JSON body, or ApiError."""
        r = self._http.request(method, path, **kw)
        if r.status_code >= 400:
            raise _error(r)
        return r.json()

    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- system --------------------------------------------------------------------
    def health(self) -> dict[str, Any]:
        return self.request("GET", "/health")

    def rig_status(self) -> dict[str, Any]:
        return self.request("GET", "/rig")

    def emergency_stop(self, reason: str = "emergency stop from a lab script") -> dict[str, Any]:
        """Output off now; no plan starts until :meth:`clear_estop`."""
        return self.request("POST", "/estop", json={"reason": reason})

    def clear_estop(self) -> dict[str, Any]:
        return self.request("POST", "/estop/clear")

    # -- plans ---------------------------------------------------------------------
    def plan_types(self) -> list[dict[str, Any]]:
        return self.request("GET", "/plan-types")

    def submit_plan(self, plan: str, submitted_by: str = "", **parameters: Any) -> dict[str, Any]:
        """Queue ``plan`` (e.g. "amplitude_sweep") with its parameters; the job."""
        body = {"plan": plan, "parameters": parameters, "submitted_by": submitted_by}
        return self.request("POST", "/plans", json=body)

    def plan(self, job_id: str) -> dict[str, Any]:
        return self.request("GET", f"/plans/{job_id}")

    def plans(self, status: str | None = None, limit: int = 50, offset: int = 0) -> dict[str, Any]:
        return self.request("GET", "/plans", params=_params(status=status, limit=limit,
                                                              offset=offset))

    def cancel_plan(self, job_id: str) -> dict[str, Any]:
        return self.request("POST", f"/plans/{job_id}/cancel")

    def continue_torque(self, job_id: str, torque_nm: float) -> dict[str, Any]:
        """Confirm the bolt torque now applied, so a plan paused for it continues."""
        return self.request("POST", f"/plans/{job_id}/torque", json={"torque_nm": torque_nm})

    def wait_plan(self, job_id: str, timeout: float = 3600.0,
                  poll_s: float = 0.5) -> dict[str, Any]:
        """Poll until the plan job has finished; the final job (TimeoutError after ``timeout``)."""
        return self._wait(lambda: self.plan(job_id), PLAN_FINISHED, timeout, poll_s)

    # -- runs ----------------------------------------------------------------------
    def runs(self, *, all_pages: bool = True, **filters: Any) -> list[dict[str, Any]]:
        """Runs matching ``filters`` (torque_nm, vpp_min, vpp_max, frequency_hz, status,
        plan, since, until, order, limit, offset); every page unless ``all_pages=False``."""
        params = _params(**filters)
        out: list[dict[str, Any]] = []
        while True:
            page = self.request("GET", "/runs", params=params)
            out += page["items"]
            if not all_pages or page["next_offset"] is None:
                return out
            params["offset"] = page["next_offset"]

    def run(self, name: str) -> dict[str, Any]:
        return self.request("GET", f"/runs/{name}")

    def channels(self, name: str) -> dict[str, Any]:
        return self.request("GET", f"/runs/{name}/channels")

    def data(self, name: str, channels: Iterable[str] = (), start: float = 0.0,
             stop: float | None = None, unit: str = "s", max_points: int = 2000) -> dict[str, Any]:
        """A slice in physical units: {"series": [{"name", "unit", "time_s", "values"}...]}."""
        params = _params(channel=list(channels), start=start, stop=stop, unit=unit,
                         max_points=max_points)
        return self.request("GET", f"/runs/{name}/data", params=params)

    def download(self, name: str, dest: str | Path) -> Path:
        """Save the run's HDF5 file at ``dest`` (a file or a directory); its path."""
        d = Path(dest)
        target = d / f"{name}.h5" if d.is_dir() else d
        with self._http.stream("GET", f"/runs/{name}/file") as r:
            if r.status_code >= 400:
                r.read()
                raise _error(r)
            tmp = target.with_name(target.name + ".part")
            with open(tmp, "wb") as fh:
                for chunk in r.iter_bytes():
                    fh.write(chunk)
            tmp.replace(target)
        return target

    def loops(self, name: str, points_per_cycle: int = 128, max_cycles: int = 8) -> dict[str, Any]:
        """The hysteresis loops of the run's last steady cycles: {"cycles": [{"displacement_m",
        "force_n", "energy_loss_j", "stiffness_n_per_m", ...}], "summary", "reason"}."""
        return self.request("GET", f"/runs/{name}/loops",
                            params={"points_per_cycle": points_per_cycle, "max_cycles": max_cycles})

    def ladders(self, name: str) -> list[dict[str, Any]]:
        """The model ladders saved in the run's file, newest first (not recomputed)."""
        return self.request("GET", f"/runs/{name}/ladders")["ladders"]

    # -- analyses and models ----------------------------------------------------------
    def submit_analysis(self, runs: Iterable[str], method: str = "hysteresis",
                        **options: Any) -> dict[str, Any]:
        body = {"runs": list(runs), "method": method, "options": options}
        return self.request("POST", "/analyses", json=body)

    def analysis(self, job_id: str) -> dict[str, Any]:
        return self.request("GET", f"/analyses/{job_id}")

    def analyze(self, runs: Iterable[str], method: str = "hysteresis", timeout: float = 600.0,
                **options: Any) -> dict[str, Any]:
        """Run a pipeline on ``runs`` and wait: the job's result {"runs": [...]}."""
        job = self.submit_analysis(runs, method, **options)
        return self._result(self._wait(lambda: self.analysis(job["id"]), JOB_FINISHED,
                                       timeout, 0.2))

    def model(self, operation: str, runs: Iterable[str], model: str, max_steps: int = 5,
              timeout: float = 3600.0, **options: Any) -> dict[str, Any]:
        """``operation`` ("fit", "diagnose", "ladder") of ``model`` on ``runs``, waited for."""
        body = {"runs": list(runs), "model": model, "max_steps": max_steps, "options": options}
        job = self.request("POST", f"/models/{operation}", json=body)
        return self._result(self._wait(lambda: self.request("GET", f"/models/jobs/{job['id']}"),
                                       JOB_FINISHED, timeout, 0.5))

    @staticmethod
    def results_table(analysis: dict[str, Any]) -> str:
        """An aligned text table of hysteresis results (display units: um, mJ, MN/m)."""
        rows = [[h for h, _, _ in TABLE_COLUMNS]]
        for r in analysis["runs"]:
            if "error" in r:
                rows.append([r["run"], "error: " + r["error"]])
                continue
            rows.append([_fmt(r.get(key), scale) for _, key, scale in TABLE_COLUMNS])
        widths = [max(len(row[i]) for row in rows if i < len(row)) for i in range(len(rows[0]))]
        return "\n".join("  ".join(c.rjust(w) if i else c.ljust(w)
                                   for i, (c, w) in enumerate(zip(row, widths))).rstrip()
                         for row in rows)

    # -- helpers -------------------------------------------------------------------
    @staticmethod
    def _wait(get: Any, finished: tuple[str, ...], timeout: float, poll_s: float) -> dict[str, Any]:
        end = time.monotonic() + timeout
        while True:
            job = get()
            if job["status"] in finished:
                return job
            if time.monotonic() > end:
                raise TimeoutError(f"job {job['id']} still {job['status']} after {timeout} s")
            time.sleep(poll_s)

    @staticmethod
    def _result(job: dict[str, Any]) -> dict[str, Any]:
        if job["status"] != "complete":
            raise JobFailed(job)
        return job["result"]


__all__ = ["ApiError", "Client", "JobFailed", "DEFAULT_URL", "ENV_TOKEN", "ENV_URL",
           "JOB_FINISHED", "PLAN_FINISHED", "TABLE_COLUMNS"]
