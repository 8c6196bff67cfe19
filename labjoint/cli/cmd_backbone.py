"""`labjoint backbone RUN...|FRF.json [--model EXPR --param NAME=VALUE ...] [--structure S.toml
| --mass KG [--stiffness N/M]] [--sensor NAME] [--amplitudes LO:HI:N] [--modal-mass KG]
[--out BACKBONE.json] [--json]`.

Measured backbones (frequency and damping ratio against the fundamental's displacement
amplitude at the response sensor) from phase-resonance level runs, a ringdown run (the
exciter's force removed with the phase resonance's apparent modal mass, when both are
given), step-sine runs or an FRF set file; the model's beside them: the extended
periodic motion concept on ``--structure`` (its joints' law, or ``--model`` with
``--param``), or the single-DOF modal form of ``--model`` with ``--mass``. ``--model``
may also name a JSON file: a saved model (``labjoint-model/1``), or the ``--json`` output
of ``labjoint fit`` or ``labjoint ladder`` (its final step), whose parameters are taken
(``--param`` overrides them). ``--out`` writes the measured backbones as a backbone file
(``labjoint.backbone/1``, :mod:`labjoint.signal.backbone`), the input of ``labjoint
fit|diagnose|ladder BACKBONE.json --structure S.toml``.
JSON (design.md): {"points": [{"amplitude", "amplitude_units", "frequency_hz",
"damping_ratio", "method", "amplitude_sd", "frequency_sd_hz", "damping_sd", ...}],
"model": [...same fields...], "notes": [...]}.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.cli.output import emit_json, table
from labjoint.cli.structure_inputs import floats
from labjoint.errors import InputError
from labjoint.signal.backbone import Backbone, save_backbones


def add_backbone_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("inputs", nargs="*", metavar="RUN|FRF.json",
                   help="phase_resonance runs (levels and ringdown), step_sine runs, or an FRF set (.json)")
    p.add_argument("--sensor", default=None, help="response sensor (default: the runs' response channel)")
    p.add_argument("--modal-mass", type=float, default=None, metavar="KG",
                   help="apparent modal mass between force and sensor (default: from the lowest "
                        "phase-resonance level's phase slope)")
    p.add_argument("--residual-compliance", default=None, metavar="M/N|S.toml",
                   help="ringdowns: the other modes' compliance between drive and sensor, taken out of "
                        "the force removal: a number (m/N) or a structure file (every other mode's "
                        "static share between --sensor and its excitation, mode --mode; default 0)")
    p.add_argument("--force-band", choices=("octave", "half_octave"), default=None,
                   help="ringdowns with a force: a lone mode's band-pass (half_octave: order 4, "
                        "shuts out the next mode's leak into F/X; default half_octave with "
                        "--residual-compliance, else octave)")
    p.add_argument("--model", default=None, metavar="EXPR|MODEL.json",
                   help="joint law, e.g. linear_stiffness+iwan, or a model file / fit or ladder JSON")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="a parameter of --model (effect.param=value), repeated")
    p.add_argument("--structure", default=None, metavar="S.toml", help="structure file: EPMC backbone")
    p.add_argument("--mode", type=int, default=1, help="mode number of the structure (default 1)")
    p.add_argument("--harmonics", type=int, default=3, help="harmonics of the EPMC balance (default 3)")
    p.add_argument("--mass", type=float, default=None, metavar="KG", help="single-DOF modal form: modal mass")
    p.add_argument("--stiffness", type=float, default=0.0, metavar="N/M",
                   help="single-DOF modal form: linear stiffness beside the law (default 0)")
    p.add_argument("--amplitudes", default=None, metavar="LO:HI:N",
                   help="model amplitudes (m at the sensor, log spaced; default: the measured range)")
    p.add_argument("--out", default=None, metavar="BACKBONE.json",
                   help="write the measured backbones as a backbone file (labjoint.backbone/1)")


def _params(items: list[str]) -> dict[str, float]:
    out = {}
    for item in items:
        key, sep, val = item.partition("=")
        if not sep:
            raise InputError(f"expected NAME=VALUE, got '{item}'", field="--param")
        out[key.strip()] = floats(val, f"--param {key}")[0]
    return out


def model_file(path: str) -> tuple[str, dict[str, float]]:
    """(model expression, parameter values) of a JSON model: a saved model file, or the
    ``--json`` output of fit/diagnose ({"model", "parameters": {name: {"value"}}}) or of a
    ladder (its last step)."""
    import json

    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"not a readable model file ({exc})", file=path, field="--model") from None
    if isinstance(d, dict) and isinstance(d.get("steps"), list) and d["steps"]:
        d = d["steps"][-1]
    if not (isinstance(d, dict) and isinstance(d.get("model"), str) and isinstance(d.get("parameters"), dict)):
        raise InputError("expected a model file or a fit/ladder JSON with 'model' and 'parameters'",
                         file=path, field="--model")
    vals = {}
    for k, v in d["parameters"].items():
        x = v.get("value") if isinstance(v, dict) else v
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise InputError(f"parameter value must be a number, got {x!r}", file=path, field=k)
        vals[k] = float(x)
    return d["model"], vals


def _law(args: argparse.Namespace) -> Any:
    from labjoint.structure.law import JointLaw

    expr, vals = args.model, {}
    if expr.lower().endswith(".json"):
        expr, vals = model_file(expr)
    return JointLaw(expr, {**vals, **_params(args.param)}, field="--model")


def _amplitudes(args: argparse.Namespace, meas: list[Backbone]) -> np.ndarray:
    if args.amplitudes:
        lo, hi, n = (floats(args.amplitudes, "--amplitudes", ":") + [0, 0, 0])[:3]
        if not (0 < lo < hi and n >= 2 and n == int(n)):
            raise InputError(f"expected LO:HI:N with 0 < LO < HI, N >= 2, got '{args.amplitudes}'",
                             field="--amplitudes")
        return np.geomspace(lo, hi, int(n))
    amps = np.concatenate([b.array("amplitude") for b in meas]) if meas else np.array([])
    if amps.size == 0:
        raise InputError("give --amplitudes LO:HI:N (m at the sensor) when no measurement is given",
                         field="--amplitudes")
    return np.geomspace(amps.min() / 1.5, amps.max() * 1.5, 20)


def modelled(args: argparse.Namespace, meas: list[Backbone]) -> Backbone | None:
    """The model's backbone asked for by ``--structure`` / ``--model`` / ``--mass``."""
    if args.structure is None and args.model is None:
        return None
    law = _law(args) if args.model else None
    A = _amplitudes(args, meas)
    if args.structure is not None:
        from labjoint.structure import load_structure
        from labjoint.structure.epmc import epmc_backbone
        from labjoint.structure.frf import system_of
        from labjoint.structure.system import JointElement

        sysm = system_of(load_structure(args.structure))
        if law is not None:
            sysm = replace(sysm, elements=tuple(JointElement(replace(e.joint, law=law)) for e in sysm.elements))
        sensor = args.sensor or (meas[0].sensor if meas else None)
        return epmc_backbone(sysm, A, mode=args.mode - 1, harmonics=args.harmonics, sensor=sensor)
    if args.mass is None:
        raise InputError("--model without --structure needs --mass (the single-DOF modal form)",
                         field="--mass")
    from labjoint.structure.sdof_backbone import sdof_backbone

    return sdof_backbone(law, A, args.mass, stiffness_n_per_m=args.stiffness)


def force_band(args: argparse.Namespace) -> str:
    """The ringdown force removal's band: as given, else the better removal (half_octave)
    where the other modes' residual compliance is known (README rig loop's ladder: 1.80x the
    noise floor with both, 1.84x with the band alone, 3.67x with the compliance alone,
    3.94x with neither), else octave (today's path where nothing says more)."""
    if args.force_band is not None:
        return args.force_band
    return "half_octave" if args.residual_compliance else "octave"


def _runs_sensor(args: argparse.Namespace) -> str | None:
    """--sensor, else the first run's response channel (the sensor the ringdown reads)."""
    if args.sensor:
        return args.sensor
    from labjoint.storage import open_run

    for name in args.inputs:
        if Path(name).suffix.lower() != ".json" and Path(name).exists():
            with open_run(name) as rf:
                return rf.metadata.get("response_channel")
    return None


def residual_compliance(args: argparse.Namespace) -> float:
    """``--residual-compliance`` in m/N: the number given, or from a structure file
    (:func:`labjoint.structure.residual.residual_compliance`, mode ``--mode``, the sensor
    as the runs name it)."""
    text = args.residual_compliance
    if text is None:
        return 0.0
    try:
        return float(text)
    except ValueError:
        pass
    if not text.lower().endswith(".toml"):
        raise InputError(f"expected a compliance in m/N or a structure file (.toml), got '{text}'",
                         field="--residual-compliance")
    from labjoint.structure import load_structure
    from labjoint.structure.residual import residual_compliance as structure_compliance

    sensor = _runs_sensor(args)
    if sensor is None:
        raise InputError("name the response sensor (--sensor) for the structure's compliance",
                         file=text, field="--residual-compliance")
    return structure_compliance(load_structure(text), sensor, args.mode, file=text)


def run(args: argparse.Namespace) -> int:
    if not args.inputs and args.structure is None and args.model is None:
        raise InputError("give runs, an FRF set, or a model (--structure / --model)", field="inputs")
    from labjoint.identify.backbone import measured_backbones

    args.residual_compliance = residual_compliance(args)
    meas = measured_backbones(args.inputs, args.sensor, args.modal_mass,
                              {"residual_compliance_m_per_n": args.residual_compliance,
                               "force_band": force_band(args)})
    model = modelled(args, meas)
    if args.out:
        if not meas:
            raise InputError("--out writes measured backbones: give runs or an FRF set", field="--out")
        save_backbones(args.out, meas, args.mode)
    points = [p.to_dict(b.amplitude_units) for b in meas for p in b.points]
    res = {"points": points, "model": [] if model is None else model.to_dict()["points"],
           "notes": [n for b in meas + ([model] if model else []) for n in b.notes],
           "sensor": (meas[0].sensor if meas else model.sensor if model else None),
           "saved": args.out}
    if args.json:
        emit_json(res)
        return 0
    rows = [(p["method"], p["amplitude"], p["frequency_hz"], p["frequency_sd_hz"], p["damping_ratio"],
             p["damping_sd"]) for p in points + res["model"]]
    print(table(("method", "amplitude_m", "frequency_hz", "sd_hz", "damping_ratio", "sd"), rows))
    return 0
