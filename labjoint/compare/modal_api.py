"""Modal records through fit, diagnose, ladder and predict (issue 29 item 5).

Options: ``modal`` (the measured modes: a file of ``labjoint modes --json``, or a
:class:`~labjoint.structure.nlmode.ModalBasis`) and ``responses`` (channels compared,
comma-separated; default every motion channel of the records). A fitted modal model is
saved as JSON (format ``labjoint.modalmodel/1``: the joint model, every parameter, the
modes, the channels) and predicted on any record of the same structure by
:func:`predict_modal` (``labjoint predict MODEL.json RECORD``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.compare.kinds.modal import ModalMeasurement, ModalSetup
from labjoint.compare.kinds.modal_prepare import prepare_modal
from labjoint.compare.runs import split_by_names
from labjoint.errors import InputError
from labjoint.models import FitResult, Model, Parameters
from labjoint.models.shaker import shaker_table
from labjoint.structure.nlmode import ModalBasis, basis_from_json, load_basis
from labjoint.structure.nlmode_shaker import ShakerPath

MODAL_OPTIONS = ("modal", "responses", "between", "joint_shape", "start", "bounds", "shaker", "drive_point",
                 "modal_mass")
FORMAT = "labjoint.modalmodel/1"


def _basis(modal: Any) -> ModalBasis:
    """The measured modes: a :class:`ModalBasis`, the JSON of ``labjoint modes --json``
    already read (a dict, as REST takes it) or the path of such a file."""
    if isinstance(modal, ModalBasis):
        return modal
    if isinstance(modal, dict):
        return basis_from_json(modal, "modal")
    return load_basis(str(modal))


def _responses(responses: Any) -> list[str] | None:
    if responses is None or isinstance(responses, (list, tuple)):
        return list(responses) if responses else None
    return [c.strip() for c in str(responses).split(",") if c.strip()]


def load_modal(items: Sequence[Any], validate: Sequence[Any] | None, options: dict[str, Any]
               ) -> tuple[list[ModalMeasurement], list[str] | None]:
    """Modal measurements of run files and the validation run names."""
    if options.get("modal") is None:
        raise InputError("the modal kind needs the measured modes: --modal MODES.json (the output "
                         "of `labjoint modes RUN --json`)", field="modal")
    other = [k for k in ("structure", "modes", "harmonics") if options.get(k) is not None]
    if other:
        raise InputError(f"{other[0]} goes with FRF sets, not with --modal", field=other[0])
    if options.get("joint_shape") and options.get("between") is None:
        raise InputError("fits the participation of a joint between two sensors: it goes with "
                         "--between A,B", field="joint_shape")
    basis = _basis(options["modal"])
    resp = _responses(options.get("responses"))
    paths = [str(x) for x in items]
    extra = [str(v) for v in (validate or []) if str(v) not in paths]
    between = _responses(options.get("between"))
    if between is not None and len(between) != 2:
        raise InputError(f"names two sensors A,B, got {options.get('between')!r}", field="between")
    ms = [prepare_modal(p, basis, resp, between=tuple(between) if between else None) for p in paths + extra]
    check_drives(ms)
    setup = ModalSetup(tuple(_starts(options.get("start")).items()),
                       tuple(_bounds(options.get("bounds")).items()),
                       shaker_path(options, basis, ms), bool(options.get("joint_shape")))
    ms = [replace(m, setup=setup) for m in ms]
    seen: dict[str, int] = {}
    for i, m in enumerate(ms):
        seen[m.name] = seen.get(m.name, 0) + 1
        if seen[m.name] > 1:
            ms[i] = m.renamed(f"{m.name}#{seen[m.name]}")
    if not validate:
        return ms, None
    _, val, _ = split_by_names(ms, [str(v) for v in validate])
    return ms, [m.name for m in val]


def shaker_path(options: dict[str, Any], basis: ModalBasis, ms: Sequence[ModalMeasurement]) -> ShakerPath | None:
    """The shaker between the voltage and mode 1, or every mode with ``between`` (``shaker``: a [shaker] table's file or a
    mapping of its fields; ``drive_point``: the sensor it drives; ``modal_mass``: mode 1's
    modal mass there, kg, when known), None without ``shaker``."""
    sh = options.get("shaker")
    if sh is None:
        for k in ("drive_point", "modal_mass"):
            if options.get(k) is not None:
                raise InputError("goes with a shaker (--shaker S.toml)", field=k)
        return None
    if not options.get("drive_point"):
        raise InputError("names the sensor the shaker drives (--drive-point SENSOR)", field="drive_point")
    for m in ms:
        if m.metadata.get("drive_quantity") != "voltage":
            raise InputError(f"run '{m.name}': the shaker is driven by a voltage; this drive is a "
                             f"{m.metadata.get('drive_quantity')} (a measured force needs no shaker)",
                             file=m.path, field="shaker")
    given = shaker_table(sh) if isinstance(sh, (str, Path)) else dict(sh)
    mm = options.get("modal_mass")
    return ShakerPath.of(given, str(options["drive_point"]), basis,
                         None if mm is None else float(mm), str(sh) if isinstance(sh, (str, Path)) else "")


def _starts(start: Any) -> dict[str, float]:
    """``start`` {name: value} checked finite (the fitter checks names and bounds)."""
    out = {}
    for k, v in (start or {}).items():
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise InputError(f"not a number: {v!r}", field=f"start.{k}") from None
        if not np.isfinite(x):
            raise InputError(f"not a finite number: {v!r}", field=f"start.{k}")
        out[str(k)] = x
    return out


def _bounds(bounds: Any) -> dict[str, tuple[float, float]]:
    """``bounds`` {name: (lo, hi)} with lo <= hi."""
    out = {}
    for k, v in (bounds or {}).items():
        try:
            lo, hi = (float(x) for x in v)
        except (TypeError, ValueError):
            raise InputError(f"expected (lo, hi), got {v!r}", field=f"bound.{k}") from None
        if not lo <= hi:
            raise InputError(f"lower bound {lo:g} above the upper {hi:g}", field=f"bound.{k}")
        out[str(k)] = (lo, hi)
    return out


def check_drives(ms: Sequence[ModalMeasurement], model_input: str | None = None) -> None:
    """Refuse a drive whose quantity is not the model's input: one ``modal.drive`` is per
    volt or per newton, never both (``model_input``: a saved model's; else the set's first)."""
    want = model_input or (ms[0].metadata.get("drive_quantity") if ms else None)
    for m in ms:
        have = m.metadata.get("drive_quantity")
        if want and have and have != want:
            whose = "the model's input" if model_input else f"run '{ms[0].name}''s drive"
            raise InputError(f"run '{m.name}': its drive '{m.metadata.get('drive_channel')}' is a {have}, "
                             f"but {whose} is a {want} (modal.drive is per "
                             f"{'volt' if want == 'voltage' else 'newton'}); a {have} is never taken "
                             f"as a {want}: fit the runs of each drive apart", file=m.path, field="drive")


def save_modal(fit: FitResult, ms: Sequence[ModalMeasurement], path: str | Path) -> None:
    """The fitted modal model as JSON, written whole or not at all."""
    vals = fit.params_.valuesdict()
    bad = [k for k, v in vals.items() if not np.isfinite(v)]
    if bad or not np.isfinite(fit.nrmse_):
        raise InputError(f"the fit is not finite ({', '.join(bad) or 'nrmse'}); nothing saved",
                         field="model")
    d = {"format": FORMAT, "model": fit.model.expr, "parameters": fit.params_.to_dict(),
         "basis": ms[0].basis.to_dict(), "channels": list(ms[0].channels),
         "nrmse": fit.nrmse_, "fit_runs": list(fit.fit_runs_),
         "drive_quantity": ms[0].metadata.get("drive_quantity")}
    if ms[0].between:
        d["between"] = list(ms[0].between)
        d["joint_shape"] = "fitted" if ms[0].setup.joint_shape else "sensors"
    if ms[0].setup.shaker is not None:
        d["shaker"] = ms[0].setup.shaker.to_dict(vals)
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(json.dumps(d, indent=1), encoding="utf-8")
    os.replace(tmp, p)


def is_modal_model(path: str | Path) -> bool:
    try:
        with open(path, encoding="utf-8") as fh:
            return FORMAT in fh.read(200)
    except OSError:
        return False


def predict_modal(model_path: str | Path, record: str | Path) -> dict[str, Any]:
    """The saved modal model on a record: per channel the NRMSE of its response over the
    judged samples, pooled NRMSE, and the measured and model series (SI, judged samples)."""
    try:
        d = json.loads(Path(model_path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the model: {exc}", file=str(model_path)) from None
    model = Model.parse(d["model"])
    params = Parameters.from_dict(d["parameters"])
    basis = ModalBasis.from_dict(d["basis"])
    between = d.get("between")
    m = prepare_modal(str(record), basis, d["channels"], between=tuple(between) if between else None)
    # with the shaker the model is per newton too: a measured force drives the structure alone
    check_drives([m], None if d.get("shaker") and m.metadata.get("drive_quantity") == "force"
                 else d.get("drive_quantity"))
    if d.get("shaker"):
        m = replace(m, setup=ModalSetup(shaker=ShakerPath.from_dict(d["shaker"])))
    vals = params.valuesdict()
    q = m.states(model, vals)
    series = m.responses(model, vals, q)
    pred = m.normalized(series)
    if not np.all(np.isfinite(pred)):
        raise InputError("the model diverges on this record", file=str(record), field="model")
    e = pred - m.data.force
    chans = {}
    for i, ch in enumerate(m.channels):
        ei, yi = e[m.channel_part(i)], m.data.force[m.channel_part(i)]
        chans[ch] = {"quantity": m.quantities[i], "nrmse": float(np.sqrt(np.mean(ei**2) / np.mean(yi**2))),
                     "measured": m.in_units(i, m.data.force).tolist(), "model": m.in_units(i, pred).tolist()}
    out = {"model": d["model"], "record": str(record), "kind": "modal",
           "nrmse": float(np.sqrt(np.mean(e**2) / np.mean(m.data.force**2))),
           "sample_rate_hz": m.drive.fs, "channels": chans}
    if d.get("shaker"):
        out.update(per_newton(m, q, series, vals))
        out["shaker"] = d["shaker"]
    return out


def per_newton(m: ModalMeasurement, q: np.ndarray, series: dict[str, np.ndarray],
               vals: dict[str, float] | None = None) -> dict[str, Any]:
    """With the shaker: the force on the structure the model gives (nlmode_shaker H2, N, on
    the judged samples) and, on a steady sine, every channel's response at the drive's
    fundamental per volt and per newton (amplitude and phase): the per-newton one is the
    per-volt one over the force per volt."""
    j = m.judged
    force = m.structure_force(q, vals or {})[j]
    out: dict[str, Any] = {"force_on_structure_n": force.tolist(),
                           "force_rms_n": float(np.sqrt(np.mean((force - force.mean()) ** 2)))}
    f = m.frequency_hz
    by_force = m.metadata.get("drive_quantity") == "force"
    if f:
        t = np.arange(j.stop - j.start) / m.drive.fs
        e = np.exp(-2j * np.pi * f * t)
        ph = lambda x: 2 * np.mean((x - x.mean()) * e)  # noqa: E731  (the fundamental's phasor)
        volts = m.drive.phasor * np.exp(2j * np.pi * f * j.start / m.drive.fs)
        fu = 1.0 if by_force else ph(force) / volts      # a force record: per newton only
        frf = {}
        for ch in m.channels:
            yv = ph(series[ch][j]) / volts
            frf[ch] = {"per_newton": {"amplitude": float(abs(yv / fu)),
                                      "phase_deg": float(np.degrees(np.angle(yv / fu)))}}
            if not by_force:
                frf[ch]["per_volt"] = {"amplitude": float(abs(yv)), "phase_deg": float(np.degrees(np.angle(yv)))}
        out["fundamental"] = {"frequency_hz": f, "channels": frf}
        if not by_force:
            out["fundamental"]["force_per_volt"] = {"amplitude": float(abs(fu)),
                                                    "phase_deg": float(np.degrees(np.angle(fu)))}
    return out
