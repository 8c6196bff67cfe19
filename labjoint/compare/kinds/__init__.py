"""Kinds of measurement the comparison works on (:mod:`labjoint.compare.measurement`).

- ``sine``: the steady cycles of a run under a steady sine (:mod:`.sine`);
- ``record``: a record under any excitation, judged sample by sample along its history
  (:mod:`.record`);
- ``frf``: constant-force stepped-sine FRFs of a structure with their harmonics, the
  model inside the structure (:mod:`.frf`, :mod:`.frf_maps`; prepared with
  :func:`labjoint.compare.kinds.frf.prepare_frfsets`);
- ``backbone``: a mode's frequency and damping against amplitude, the model's by EPMC
  inside the structure (:mod:`.backbone`, :mod:`.backbone_maps`; prepared with
  :func:`labjoint.compare.kinds.backbone.prepare_backbones`);
- ``modal``: records of a structure nobody can describe, inside a modal model of its
  measured modes with the joint on mode 1, judged on the measured responses
  (:mod:`.modal`, :mod:`.modal_fit`, :mod:`.modal_project`, :mod:`.modal_maps`; prepared
  with :func:`.modal_prepare.prepare_modal`).

FRF sweeps and backbones of one structure may be judged together, in one fit and one
diagnosis (:mod:`.combined`); any other mixture of kinds is refused.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from labjoint.compare.kinds.backbone_maps import BACKBONE
from labjoint.compare.kinds.combined import COMBINABLE, CombinedKind
from labjoint.compare.kinds.frf import FrfMeasurement
from labjoint.compare.kinds.frf_maps import FRF
from labjoint.compare.kinds.modal_maps import MODAL
from labjoint.compare.kinds.record import RECORD, RecordMeasurement, prepare_record
from labjoint.compare.kinds.sine import SINE
from labjoint.identify.plausible import Plausibility, refuse_large_record
from labjoint.compare.measurement import Kind, Measurement
from labjoint.compare.prepared import PreparedRun
from labjoint.compare.runs import prepare_run
from labjoint.errors import InputError
from labjoint.signal import validate
from labjoint.signal.excitation import Excitation, detect_excitation
from labjoint.storage import Run, read_any
from labjoint.storage.roles import channel_roles

KINDS: dict[str, Kind] = {SINE.name: SINE, RECORD.name: RECORD, FRF.name: FRF, BACKBONE.name: BACKBONE,
                        MODAL.name: MODAL}


def kind_of(ms: Sequence[Measurement]) -> Kind:
    """The one kind of a set of measurements; FRF sweeps with backbones, the kind that
    judges them together (:mod:`.combined`); any other mixture is refused."""
    names = sorted({m.kind for m in ms})
    if not names:
        raise InputError("no measurements given", field="runs")
    if len(names) > 1:
        if set(names) <= COMBINABLE:
            return CombinedKind({n: KINDS[n] for n in names})
        raise InputError(f"the runs mix kinds of measurement {names} that cannot be judged "
                         f"together (only {' and '.join(sorted(COMBINABLE))} of one structure "
                         "can); prepare them all as one kind (kind='record' takes any "
                         "excitation)", field="runs")
    return KINDS[names[0]]


#: what the joint models take and give: the relative displacement in, the joint force out
#: (by equation error), or the force in and the displacement out (by simulation error)
MODEL_QUANTITIES = {"displacement": "displacement", "force": "force"}


def check_quantities(run: Run) -> None:
    """Refuse a run whose force or displacement channel states another quantity (a
    voltage where the model needs a force, an acceleration where it needs a displacement),
    by the channels' ``channel_quantities`` metadata when the file carries it; one line
    naming the run and the channel."""
    q = run.metadata.get("channel_quantities") or {}
    if not isinstance(q, dict) or not q:
        return
    roles = channel_roles(run.metadata, run.channels)
    for role, names in (("force", [roles.joint_force]), ("displacement", list(roles.displacement))):
        for name in names:
            have = q.get(name)
            if have is not None and str(have) != MODEL_QUANTITIES[role]:
                raise InputError(f"run '{run.name}': channel '{name}' is a {have}, but a joint "
                                 f"model's {role} must be a measured {role} (a {have} is never "
                                 f"taken as one); map the {role} channel, or a shaker model "
                                 "between the drive and the structure", file=run.path,
                                 field=name)


def _check_signals(r: Run) -> None:
    """Finite signals whose squares do not overflow, named with the run (before the mains
    filter and the fits square them)."""
    for name in ("displacement", "force", "excitation"):
        x = getattr(r, name, None)
        if x is None:
            continue
        try:
            validate.signal(x, name)
        except InputError as e:
            raise InputError(f"run '{r.name}': {e.message}", file=r.path, field=name) from None


def _excitation(r: Run) -> Excitation:
    try:
        return detect_excitation(r.excitation, r.sample_rate_hz, dict(r.metadata))
    except InputError as e:
        raise InputError(f"run '{r.name}': {e.message}", file=r.path,
                         field="excitation") from None


def prepare(runs: Iterable[Any], *, kind: str = "auto", prime_cycles: int | str = "auto",
            warmup: str | float = "auto", plausibility: Plausibility | None = None) -> list[Measurement]:
    """Measurements of one kind from run-file or CSV paths, Runs or prepared measurements
    (these pass through); names made unique.

    ``kind``: "sine" (steady cycles), "record" (any excitation, along the history) or
    "auto": sine when every run's force is a steady sine
    (:func:`labjoint.signal.excitation.detect_excitation`), else record for all of them,
    so that one set is judged one way.
    ``plausibility``: the sine kind's limits (:mod:`labjoint.identify.plausible`); the
    displacement cap is checked on every run's samples before any run is prepared (a
    refusal in seconds, not after the slow part).
    """
    if kind not in ("auto", *KINDS):
        raise InputError(f"unknown kind {kind!r}; known: auto, {', '.join(KINDS)}", field="kind")
    if kind == "modal":
        raise InputError("the modal kind takes records with the measured modes (prepare_modal, or "
                         "the modal option: --modal MODES.json)", field="kind")
    if kind in ("frf", "backbone"):
        raise InputError(f"the {kind} kind takes {'FRF sets' if kind == 'frf' else 'backbones'} inside "
                         f"a structure (prepare_{'frfsets' if kind == 'frf' else 'backbones'}, or the "
                         "structure option), not runs", field="kind")
    items = [read_any(r) if isinstance(r, (str, Path)) else r for r in runs]
    if not items:
        raise InputError("no runs given", field="runs")
    for r in items:
        if isinstance(r, Run):
            check_quantities(r)
            _check_signals(r)
    found = {id(r): _excitation(r)
             for r in items if isinstance(r, Run) and kind in ("auto", "sine")}
    if kind == "sine":
        for r in items:
            e = found.get(id(r))
            if e is not None and e.kind != "sine":
                raise InputError(f"run '{r.name}' holds {e.describe()}, not a steady sine, so it "
                                 "cannot be judged as the sine kind; judge it along its history "
                                 "with kind='record' (CLI --kind record) or let kind='auto' "
                                 "choose", file=r.path, field="kind")
    if kind == "auto":
        given = {r.kind for r in items if isinstance(r, (PreparedRun, RecordMeasurement))}
        sine = all(e.kind == "sine" for e in found.values())
        kind = "sine" if sine and given <= {"sine"} else "record"
    if kind == "sine":
        for r in items:
            if isinstance(r, Run):
                refuse_large_record(r.displacement, plausibility, f"run '{r.name}': ")
    out: list[Measurement] = []
    for r in items:
        if isinstance(r, FrfMeasurement):
            raise InputError("FRF measurements are prepared with prepare_frfsets (they need "
                             "the structure)", field="runs")
        if isinstance(r, (PreparedRun, RecordMeasurement)):
            if r.kind != kind:
                raise InputError(f"run '{r.name}' was prepared as {r.kind}, the set as {kind}",
                                 field="kind")
            out.append(r)
        elif isinstance(r, Run):
            out.append(prepare_run(r, prime_cycles=prime_cycles, plausibility=plausibility)
                       if kind == "sine"
                       else prepare_record(r, warmup=warmup, excitation=found.get(id(r))))
        else:
            raise InputError(f"expected a run file path or a Run, got {type(r).__name__}",
                             field="runs")
    seen: dict[str, int] = {}
    for i, m in enumerate(out):
        seen[m.name] = seen.get(m.name, 0) + 1
        if seen[m.name] > 1:
            out[i] = m.renamed(f"{m.name}#{seen[m.name]}")
    return out


__all__ = ["KINDS", "kind_of", "prepare", "SINE", "RECORD", "FRF", "MODAL"]
