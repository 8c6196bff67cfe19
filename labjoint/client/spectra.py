"""The client's FRF, modes and distortion methods (issue 28). A mixin of
:class:`labjoint.client.Client` (it calls the client's ``request``, ``_wait`` and
``_result``)."""

from __future__ import annotations

from typing import Any, Iterable

from labjoint.client.base import JOB_FINISHED, _params


class SpectraMixin:
    """FRFs, modes and distortion of runs (:class:`labjoint.client.Client` has these methods)."""

    request: Any
    _wait: Any
    _result: Any

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
