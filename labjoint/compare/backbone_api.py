"""Backbone files through the comparison functions the CLI and REST call (fit, diagnose,
ladder), alone or together with FRF sets of the same structure.

A backbone file is a JSON file whose ``format`` key is ``labjoint.backbone/1``
(:mod:`labjoint.signal.backbone`; ``labjoint backbone RUN... --out B.json`` writes one).
Like an FRF set it is compared inside a structure (the ``structure`` option, with
``modes`` and ``harmonics``: :mod:`labjoint.compare.frf_api`); the mode is the file's.
Each backbone of a file (one per method: phase resonance, ringdown, step sine) is one
measurement, named ``<file stem>:<method>``, split into its even and odd points by
amplitude (:func:`labjoint.compare.kinds.backbone.prepare_backbones`). FRF set files (or
step-sine runs) given beside backbone files are prepared on the same structure model and
judged with them in one comparison (:mod:`labjoint.compare.kinds.combined`).
Option ``linear_damping``: "file" (default: the structure file's damping) or "measured"
(the structure's damping scaled to the backbones' low-amplitude linear range, for the
backbones and the FRF sets beside them: :mod:`labjoint.compare.backbone_damping`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from labjoint.compare.backbone_damping import CHOICES, calibrate
from labjoint.compare.frf_api import MAX_HARMONICS, _predictor, is_frfset, load_frf
from labjoint.compare.kinds.backbone import prepare_backbones
from labjoint.errors import InputError
from labjoint.signal.backbone import Backbone, is_backbone_file, load_backbones

#: points a backbone needs to be compared: its even points fit, the odd one between validates
MIN_POINTS = 3


def is_backbone(item: Any) -> bool:
    """A Backbone, or a JSON file whose format key says it is a backbone file."""
    return isinstance(item, Backbone) or is_backbone_file(item)


def _named(items: Sequence[Any]) -> list[tuple[str, Backbone, int, str | None]]:
    """(name, backbone, 0-based mode, file) of every backbone, checked for enough points."""
    out = []
    for i, it in enumerate(items):
        if isinstance(it, Backbone):
            out.append((f"backbone{i}:{_method(it)}", it, 0, None))
            continue
        bs, mode = load_backbones(it)
        for b in bs:
            out.append((f"{Path(it).stem}:{_method(b)}", b, mode - 1, str(it)))
    seen: dict[str, int] = {}
    for i, (name, b, mode, path) in enumerate(out):      # two files of one stem: names kept apart
        seen[name] = seen.get(name, 0) + 1
        if seen[name] > 1:
            out[i] = (f"{name}#{seen[name]}", b, mode, path)
    for name, b, _, path in out:
        if len(b.points) < MIN_POINTS:
            raise InputError(f"backbone '{name}' has {len(b.points)} point(s): too few to compare "
                             f"(at least {MIN_POINTS}: its every other amplitude is fitted, the "
                             "points between validate); measure more levels, or leave it out",
                             file=path, field="points")
    return out


def _method(b: Backbone) -> str:
    return "+".join(dict.fromkeys(p.method for p in b.points)) or "backbone"


def load_structural(items: Sequence[Any], validate: Sequence[Any] | None, options: dict[str, Any]
                    ) -> tuple[list[Any], list[str] | None]:
    """Measurements of backbone files (or Backbones) and of FRF sets or step-sine runs
    beside them, on one structure model; and the validation names (measurements whose
    name, file stem or part before ``/``, ``:`` or ``@`` is in ``validate``)."""
    if options.get("structure") is None:
        raise InputError("backbones are compared inside a structure: give the structure file "
                         "(--structure STRUCTURE.toml)", field="structure")
    bb = [it for it in items if is_backbone(it)]
    rest = [it for it in items if not is_backbone(it)]
    odd = [str(it) for it in rest if not is_frfset(it)
           and not (isinstance(it, (str, Path)) and Path(it).suffix.lower() in (".h5", ".hdf5"))]
    if odd:
        raise InputError(f"{', '.join(odd[:3])} cannot be judged with backbones: only FRF sets (or "
                         "the step-sine runs to make one of) of the same structure combine with "
                         "them; compare the others on their own", field="runs")
    named = _named(bb)
    ms: list[Any] = []
    if rest:
        ms, _ = load_frf(rest, None, options)
        pr = ms[0].predictor
    else:
        h = options.get("harmonics")
        if h is not None and (isinstance(h, bool) or not isinstance(h, int) or not 1 <= h <= MAX_HARMONICS):
            raise InputError(f"must be a whole number in [1, {MAX_HARMONICS}], got {h!r}", field="harmonics")
        pr = _predictor(options.get("structure"), options.get("modes"), h or MAX_HARMONICS)
    modes = {m for _, _, m, _ in named}
    how = options.get("linear_damping") or "file"
    if how not in CHOICES:
        raise InputError(f"must be one of {', '.join(CHOICES)}, got {how!r}", field="linear_damping")
    note = None
    if how == "measured":
        if len(modes) > 1:
            raise InputError("the linear damping is identified from one mode's backbones; the files "
                             f"hold modes {', '.join(str(m + 1) for m in sorted(modes))}",
                             field="linear_damping")
        mode = next(iter(modes))
        pr, note = calibrate(pr, [b for _, b, _, _ in named], mode)
        ms = [replace(m, predictor=pr) for m in ms]           # FRF sets beside: the same structure
    for mode in sorted(modes):
        part = [(n, b) for n, b, m, _ in named if m == mode]
        for meas in prepare_backbones(part, pr, mode, pr.harmonics):
            src = next(p for n, _, m, p in named if m == mode and meas.name.startswith(f"{n}/"))
            if note:
                meas.metadata["linear_damping"] = note
            ms.append(meas if src is None else replace(meas, path=src))
    if not validate:
        return ms, None
    want = {str(v) for v in validate} | {Path(str(v)).stem for v in validate}
    val = [m.name for m in ms if m.name in want or any(m.name.split(c)[0] in want for c in "/:@")]
    if not val:
        raise InputError(f"none of {sorted(map(str, validate))} names a backbone, FRF set or sweep "
                         "given", field="validate")
    return ms, val

