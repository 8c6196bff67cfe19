"""The client's structure and backbone methods (issue 15, 30): structure files, stage-1 and
stage-2 updating, model FRFs and curves, backbones, and model jobs on FRF sets and stored
backbones. A mixin of :class:`labjoint.client.Client` (it calls the client's ``request``,
``_wait`` and ``_result``)."""

from __future__ import annotations

from typing import Any, Iterable

from labjoint.client.base import JOB_FINISHED


class StructuresMixin:
    """Structures and backbones (:class:`labjoint.client.Client` has these methods)."""

    request: Any
    _wait: Any
    _result: Any

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
