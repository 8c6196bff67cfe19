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

import math
import os
import time
from pathlib import Path
from typing import Any, Iterable

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


class Client:
    """The REST API at ``base_url`` (default ``$LABJOINT_API_URL`` or 127.0.0.1:8000).

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

    # -- structures (issue 15) -----------------------------------------------------
    def backbones(self, runs: Iterable[str], modal_mass_kg: float | None = None,
                  sensor: str | None = None, save_as: str | None = None, mode: int = 1,
                  overwrite: bool = False) -> dict[str, Any]:
        """Frequency and damping against amplitude of catalogued runs (phase_resonance
        levels and ringdown, or step_sine runs): ``{"points", "notes", "sensor", "saved"}``;
        ``save_as`` stores them as the backbone file ``backbones/<save_as>.json`` (of mode
        ``mode``) for :meth:`backbone_model`."""
        body: dict[str, Any] = {"runs": list(runs)}
        if modal_mass_kg is not None:
            body["modal_mass_kg"] = modal_mass_kg
        if sensor is not None:
            body["sensor"] = sensor
        if save_as is not None:
            body.update(save_as=save_as, mode=mode, overwrite=overwrite)
        return self.request("POST", "/backbones", json=body)

    def stored_backbones(self) -> list[str]:
        """Names of the stored backbone files."""
        return self.request("GET", "/backbones")["backbones"]

    def stored_backbone(self, name: str) -> dict[str, Any]:
        """A stored backbone file: {"format", "mode", "backbones": [...]}."""
        return self.request("GET", f"/backbones/{name}")

    def backbone_model(self, operation: str, structure: str, backbones: Iterable[str], model: str,
                       frfsets: Iterable[str] = (), max_steps: int = 3, timeout: float = 3600.0,
                       **options: Any) -> dict[str, Any]:
        """``operation`` ("fit", "diagnose", "ladder") of a joint model inside ``structure`` on
        stored backbones, with FRF sets judged beside them in one comparison; waited for."""
        return self.frf_model(operation, structure, frfsets, model, max_steps, timeout,
                              backbones=list(backbones), **options)

    def structures(self) -> dict[str, list[str]]:
        """Structure files and FRF sets of the data directory: {"structures", "frfsets"}."""
        return self.request("GET", "/structures")

    def structure_modes(self, name: str, count: int = 4) -> dict[str, Any]:
        return self.request("GET", f"/structures/{name}/modes", params={"count": count})

    def _structure_job(self, path: str, body: dict[str, Any], timeout: float) -> dict[str, Any]:
        job = self.request("POST", path, json=body)
        return self._result(self._wait(lambda: self.request("GET", f"/structures/jobs/{job['id']}"),
                                       JOB_FINISHED, timeout, 0.5))

    def structure_update(self, name: str, measured_hz: Iterable[float], parameter: str = "E_e_pa",
                         timeout: float = 600.0) -> dict[str, Any]:
        """Stage-1 updating from measured natural frequencies, waited for."""
        return self._structure_job(f"/structures/{name}/update",
                                   {"measured_hz": list(measured_hz), "parameter": parameter}, timeout)

    def structure_frf(self, name: str, force_n: float, band_hz: tuple[float, float],
                      harmonics: int = 3, modes: int = 10, timeout: float = 600.0) -> dict[str, Any]:
        """Model FRF at constant force over ``band_hz``, waited for."""
        return self._structure_job(f"/structures/{name}/frf",
                                   {"force_n": force_n, "band_hz": list(band_hz),
                                    "harmonics": harmonics, "modes": modes}, timeout)

    def structure_curves(self, name: str, frfsets: Iterable[str], model: str,
                         parameters: dict[str, float], points: int = 200, margin: float = 0.25,
                         modes: int = 10, timeout: float = 600.0) -> dict[str, Any]:
        """The joint model ``model`` with ``parameters`` evaluated densely beside the
        measured steps of each sweep of the FRF sets (every sensor and harmonic, magnitude
        per newton and phase), waited for."""
        return self._structure_job(f"/structures/{name}/curves",
                                   {"frfsets": list(frfsets), "model": model,
                                    "parameters": dict(parameters), "points": points,
                                    "margin": margin, "modes": modes}, timeout)

    def structure_stage2(self, name: str, frfsets: Iterable[str],
                         parameters: Iterable[str] | None = None, modes: int = 10,
                         timeout: float = 3600.0) -> dict[str, Any]:
        """Stage-2 updating of the joint law on FRF sets (seed 000 Eq. 9), waited for."""
        return self._structure_job(f"/structures/{name}/stage2",
                                   {"frfsets": list(frfsets), "modes": modes,
                                    "parameters": None if parameters is None else list(parameters)},
                                   timeout)

    def frf_model(self, operation: str, structure: str, frfsets: Iterable[str], model: str,
                  max_steps: int = 3, timeout: float = 3600.0, backbones: Iterable[str] = (),
                  **options: Any) -> dict[str, Any]:
        """``operation`` ("fit", "diagnose", "ladder") of a joint model inside ``structure`` on
        FRF sets (and stored backbones beside them), waited for."""
        body = {"frfsets": list(frfsets), "model": model, "max_steps": max_steps,
                "options": options}
        if backbones:
            body["backbones"] = list(backbones)
        job = self.request("POST", f"/structures/{structure}/models/{operation}", json=body)
        return self._result(self._wait(lambda: self.request("GET", f"/models/jobs/{job['id']}"),
                                       JOB_FINISHED, timeout, 0.5))

    # -- FRFs, modes and distortion (issue 28) ------------------------------------
    def _spectra_job(self, path: str, body: dict[str, Any], timeout: float) -> dict[str, Any]:
        job = self.request("POST", f"/spectra/{path}", json=body)
        return self._result(self._wait(lambda: self.request("GET", f"/spectra/jobs/{job['id']}"),
                                       JOB_FINISHED, timeout, 0.3))

    def frf(self, runs: Iterable[str], name: str, band: str | tuple[float, float] = "drive",
            overwrite: bool = False, timeout: float = 3600.0, **options: Any) -> dict[str, Any]:
        """FRFs (H1/H2/Hv, coherence, std) of broadband runs, one level per run, stored as
        the FRF set ``name``; waited for: ``labjoint frf --json``'s answer ({"path",
        "format", "levels", "name"}). ``options``: drive, responses (a list), estimator,
        method, burst ("block" or "driven"), nperseg, overlap, window."""
        body = {"runs": list(runs), "name": name, "overwrite": overwrite,
                "band": band if isinstance(band, str) else list(band), **_params(**options)}
        return self._spectra_job("frf", body, timeout)

    def frf_set(self, name: str) -> dict[str, Any]:
        """A stored FRF set (the ``labjoint.frfset/1`` JSON; ``FrfSet.from_dict`` reads it)."""
        return self.request("GET", f"/spectra/frf/{name}")

    def frf_sets(self) -> list[str]:
        """Names of the stored FRF sets."""
        return self.request("GET", "/spectra/frf")["frfsets"]

    def modes(self, runs: Iterable[str] | None = None, frfsets: Iterable[str] | None = None,
              band: tuple[float, float] | None = None, order: int | None = None,
              timeout: float = 3600.0, **options: Any) -> dict[str, Any]:
        """Natural frequency, damping ratio and mode shape per level, of runs or of stored
        FRF sets (one of the two); waited for: ``labjoint modes --json``'s {"levels"}."""
        body = _params(runs=None if runs is None else list(runs),
                       frfsets=None if frfsets is None else list(frfsets),
                       band=None if band is None else list(band), order=order, **options)
        return self._spectra_job("modes", body, timeout)

    def distortion(self, runs: Iterable[str], drive: str | None = None, orders: int = 5,
                   blocks: int = 8, bands: int = 6, timeout: float = 600.0) -> dict[str, Any]:
        """Harmonic ratios per channel (steady sines) or odd/even distortion per band
        (multisines); waited for: ``labjoint distortion --json``'s {"runs"}."""
        body = _params(runs=list(runs), drive=drive, orders=orders, blocks=blocks, bands=bands)
        return self._spectra_job("distortion", body, timeout)

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


__all__ = ["ApiError", "Client", "JobFailed"]
