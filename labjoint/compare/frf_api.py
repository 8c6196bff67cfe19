"""FRF sets through the comparison functions the CLI and REST call (fit, diagnose, ladder).

An FRF set file is a JSON file whose ``format`` key is ``labjoint.frfset/1``
(:mod:`labjoint.signal.frfset`); it is compared inside a structure, given by the
``structure`` option (a TOML path or a :class:`~labjoint.structure.Structure`), with
``modes`` (Craig-Bampton kept modes, default 10) and ``harmonics`` (response harmonics
compared, default all of the set's, at most 3). Step-sine run files given with a
structure are made into one FRF set first (:func:`from_runs`); FRF set files and runs
cannot be mixed in one call. Results are saved beside the FRF files
as ``<stem>.model_<operation>_<key>.json`` (the FRF file is never rewritten; key: 12 hex
digits of the files, the model and the operation, so asking the same question again
replaces the earlier answer).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from labjoint.compare.kinds.frf import FrfMeasurement, prepare_frfsets
from labjoint.compare.jsonsafe import clean
from labjoint.errors import InputError
from labjoint.signal.frf_steps import frfset_from_runs
from labjoint.signal.frfset import FORMAT, FrfSet
from labjoint.storage.reader import open_run
from labjoint.structure import Structure, load_structure
from labjoint.structure.frf import DEFAULT_MODES
from labjoint.structure.predict import FrfPredictor

FRF_OPTIONS = ("structure", "modes", "harmonics", "linear_damping")
MAX_HARMONICS = 3
_PREDICTORS: dict[tuple, FrfPredictor] = {}


def is_frfset(item: Any) -> bool:
    """An FrfSet, or a JSON file whose format key says it is one."""
    if isinstance(item, (FrfSet, FrfMeasurement)):
        return True
    if not isinstance(item, (str, Path)) or Path(item).suffix.lower() != ".json":
        return False
    try:
        with open(item, encoding="utf-8") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    return FORMAT in head


def _predictor(structure: Any, modes: Any, harmonics: int) -> FrfPredictor:
    if structure is None:
        raise InputError("FRF sets are compared inside a structure: give the structure file "
                         "(--structure STRUCTURE.toml)", field="structure")
    if modes is not None and (isinstance(modes, bool) or not isinstance(modes, int) or modes < 0):
        raise InputError(f"must be a whole number >= 0, got {modes!r}", field="modes")
    if isinstance(structure, Structure):
        return FrfPredictor(structure, DEFAULT_MODES if modes is None else modes, harmonics)
    p = Path(str(structure))
    try:
        key = (str(p.resolve()), p.stat().st_mtime_ns, modes, harmonics)
    except OSError:
        raise InputError(f"{p}: no such structure file", field="structure") from None
    if key not in _PREDICTORS:
        _PREDICTORS.clear()
        _PREDICTORS[key] = FrfPredictor(load_structure(p), DEFAULT_MODES if modes is None else modes,
                                        harmonics)
    return _PREDICTORS[key]


def load_frf(items: Sequence[Any], validate: Sequence[Any] | None, options: dict[str, Any]
             ) -> tuple[list[FrfMeasurement], list[str] | None]:
    """Measurements of FRF set files or objects, or of step-sine run files (one set named
    ``runs``), and the validation names (measurements whose name or file is in ``validate``)."""
    h = options.get("harmonics")
    if h is not None and (isinstance(h, bool) or not isinstance(h, int) or not 1 <= h <= MAX_HARMONICS):
        raise InputError(f"must be a whole number in [1, {MAX_HARMONICS}], got {h!r}", field="harmonics")
    frf = [it for it in items if is_frfset(it)]
    runs = [it for it in items if not is_frfset(it)]
    if frf and runs:
        raise InputError(f"FRF sets ({', '.join(map(str, frf[:3]))}) and step-sine runs "
                         f"({', '.join(map(str, runs[:3]))}) cannot be mixed: give either FRF set "
                         "files or the runs to make one of", field="runs")
    sets = []
    for i, it in enumerate(frf):
        if isinstance(it, FrfSet):
            sets.append((str(it.metadata.get("name", f"frf{i}")), it))
        else:
            fs = FrfSet.load(it)
            fs.metadata["path"] = str(it)
            sets.append((Path(it).stem, fs))
    if runs:
        H0 = h or MAX_HARMONICS
        pr = _predictor(options.get("structure"), options.get("modes"), H0)
        sets.append(("runs", from_runs(runs, pr.system.output_names, H0)))
    H = min(max(fs.harmonics for _, fs in sets), h or MAX_HARMONICS)
    pr = _predictor(options.get("structure"), options.get("modes"), H)
    ms = prepare_frfsets(sets, pr, H)
    if not validate:
        return ms, None
    want = {str(v) for v in validate} | {Path(str(v)).stem for v in validate}
    val = [m.name for m in ms if m.name in want or m.name.split("@")[0] in want]
    if not val:
        raise InputError(f"none of {sorted(map(str, validate))} names an FRF set or sweep given",
                         field="validate")
    return ms, val


def from_runs(runs: Sequence[Any], sensors: Sequence[str], harmonics: int) -> FrfSet:
    """The FRF set of step-sine run files, responses at the structure's ``sensors`` that the
    runs record (InputError naming them if none does)."""
    paths = [Path(str(r)) for r in runs]
    bad = [str(p) for p in paths if p.suffix.lower() not in (".h5", ".hdf5")]
    if bad:
        raise InputError(f"{', '.join(bad[:3])}: neither an FRF set (JSON) nor a step-sine run "
                         "file (.h5)", field="runs")
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise InputError(f"{', '.join(missing[:3])}: no such file", field="runs")
    with open_run(paths[0]) as rf:
        have = set(rf.channel_names)
    use = [s for s in sensors if s in have]
    if not use:
        raise InputError(f"{paths[0]}: records none of the structure's sensors "
                         f"({', '.join(sensors)}); channels: {', '.join(sorted(have))}", field="sensors")
    fs = frfset_from_runs(paths, sensors=use, harmonics=harmonics)
    fs.metadata["name"] = "runs"
    return fs


def result_key(paths: Sequence[str], model: str, operation: str) -> str:
    h = hashlib.sha256(json.dumps([sorted(paths), model, operation]).encode()).hexdigest()
    return h[:12]


def save_beside(result: dict[str, Any], ms: Sequence[FrfMeasurement], model: str,
                operation: str) -> list[str]:
    """Write ``result`` beside each FRF file of ``ms`` (module docstring); the files written."""
    paths = sorted({m.path for m in ms if m.path})
    key = result_key(paths, model, operation)
    out = []
    for p in paths:
        target = Path(p).with_name(f"{Path(p).stem}.model_{operation}_{key}.json")
        tmp = target.with_name(f".{target.name}.tmp")
        tmp.write_text(json.dumps(clean(result), allow_nan=False))
        os.replace(tmp, target)
        out.append(str(target))
    return out
