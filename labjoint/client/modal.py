"""The client's modal-kind methods (issue 29 item 5): fit, diagnose and ladder of a joint
in a structure known only by its measured modes, and a stored modal model's prediction on
runs it never saw. A mixin of :class:`labjoint.client.Client` (it calls the client's
``request``, ``_wait`` and ``_result``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterable, Mapping

from labjoint.client.base import JOB_FINISHED


class ModalMixin:
    """The modal kind over REST (:class:`labjoint.client.Client` has these methods)."""

    request: Any
    _wait: Any
    _result: Any

    def modal_model(self, operation: str, runs: Iterable[str], model: str,
                    modes: str | Path | Mapping[str, Any], between: tuple[str, str] | None = None,
                    shaker: Mapping[str, float] | None = None, drive_point: str | None = None,
                    modal_mass: float | None = None, responses: Iterable[str] | None = None,
                    start: Mapping[str, float] | None = None,
                    bounds: Mapping[str, tuple[float, float]] | None = None,
                    save_as: str | None = None, max_steps: int = 3, timeout: float = 3600.0,
                    **options: Any) -> dict[str, Any]:
        """``operation`` ("fit", "diagnose", "ladder") of ``model`` on the modal kind, waited
        for. ``modes``: a stored FRF set or modes file's name (``frf/<name>.json``), a local
        modes JSON file (``labjoint modes --json``'s, uploaded) or its parsed JSON;
        ``between``: the joint between two sensors (else on mode 1; ``joint_shape=True``
        fits its participation in modes 2..N); ``shaker``: the
        ``[shaker]`` table's fields, with ``drive_point`` and ``modal_mass``; ``save_as``
        (fit): store the model as ``models/<save_as>.json`` for :meth:`predict`."""
        if isinstance(modes, Path) or (isinstance(modes, str) and modes.endswith(".json")):
            modes = json.loads(Path(modes).read_text(encoding="utf-8"))
        opts = dict(modal=dict(modes) if isinstance(modes, Mapping) else modes,
                       between=None if between is None else list(between),
                       shaker=None if shaker is None else dict(shaker), drive_point=drive_point,
                       modal_mass=modal_mass, responses=None if responses is None else list(responses),
                       start=None if start is None else dict(start),
                       bounds=None if bounds is None else {k: list(v) for k, v in bounds.items()},
                       save_as=save_as, **options)
        opts = {k: v for k, v in opts.items() if v is not None}
        body = {"runs": list(runs), "model": model, "max_steps": max_steps, "options": opts}
        job = self.request("POST", f"/models/{operation}", json=body)
        return self._result(self._wait(lambda: self.request("GET", f"/models/jobs/{job['id']}"),
                                       JOB_FINISHED, timeout, 0.5))

    def predict(self, model_file: str, runs: Iterable[str], full: bool = False,
                timeout: float = 600.0) -> dict[str, Any]:
        """A stored modal model (``save_as`` of a fit) on ``runs``, waited for:
        {"model_file", "runs": [``labjoint predict --json``'s answer per run]}."""
        body = {"model_file": model_file, "runs": list(runs), "full": full}
        job = self.request("POST", "/models/predict", json=body)
        return self._result(self._wait(lambda: self.request("GET", f"/models/jobs/{job['id']}"),
                                       JOB_FINISHED, timeout, 0.3))
