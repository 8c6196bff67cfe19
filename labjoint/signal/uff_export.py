"""Export a run as a universal file (UFF data-set 58, with pyuff) for other modal tools.

Written per run (SI units, the unit exponents set in records 8-10 of each data-set):

- time records (function type 1, time response, evenly spaced at 1/fs, real double):
  the joint displacement (node 1, +X; data type 8, displacement, m) and the applied
  force (node 2, +X; data type 13, excitation force, N);
- the FRF (function type 4, complex double) of the displacement at node 1 over the force
  at node 2 (receptance, m/N), H1 (:func:`labjoint.signal.frf.frf_h1`), at the excited
  lines of a periodic excitation (unevenly spaced abscissa) or on the estimator's grid
  (one block per burst, or Welch over a steady random drive's active part), and its
  coherence (function type 6, real double) on the same abscissa.

The file is written under a temporary name and renamed when complete.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.frf import FRF, frf_h1
from labjoint.storage.run import Run

DISPLACEMENT_NODE, FORCE_NODE = 1, 2
#: UFF 58 specific data types used here
TIME, FREQUENCY, DISPLACEMENT, EXCITATION_FORCE, GENERAL = 17, 18, 8, 13, 1
#: (length, force) unit exponents of each specific data type (SI: m, N)
_EXPONENTS = {DISPLACEMENT: (1, 0), EXCITATION_FORCE: (0, 1), TIME: (0, 0), FREQUENCY: (0, 0),
              GENERAL: (0, 0)}
_LABELS = {DISPLACEMENT: "m", EXCITATION_FORCE: "N", TIME: "s", FREQUENCY: "Hz", GENERAL: "-"}


def _axes(prefix: str, kind: int) -> dict[str, Any]:
    le, fe = _EXPONENTS[kind]
    return {f"{prefix}_spec_data_type": kind, f"{prefix}_len_unit_exp": le,
            f"{prefix}_force_unit_exp": fe, f"{prefix}_temp_unit_exp": 0,
            f"{prefix}_axis_units_lab": _LABELS[kind]}


def _time_set(run: Run, name: str, x: np.ndarray, node: int, kind: int) -> dict[str, Any]:
    import pyuff

    return pyuff.prepare_58(
        binary=0, id1=f"{run.name} {name}"[:80], id2=f"labjoint run {run.name}"[:80],
        id3=str(run.metadata.get("start_time", ""))[:80], id4="time record", id5="",
        func_type=1, ver_num=0, load_case_id=0, rsp_ent_name=name[:10], rsp_node=node,
        rsp_dir=1, ref_ent_name="NONE", ref_node=0, ref_dir=0, ord_data_type=4,
        num_pts=int(x.size), abscissa_spacing=1, abscissa_min=0.0,
        abscissa_inc=1.0 / float(run.sample_rate_hz), z_axis_value=0.0,
        **_axes("abscissa", TIME), **_axes("ordinate", kind),
        **_axes("orddenom", GENERAL), **_axes("z_axis", GENERAL),
        data=np.asarray(x, dtype=float), x=np.arange(x.size) / float(run.sample_rate_hz))


def _frf_sets(run: Run, frf: FRF) -> list[dict[str, Any]]:
    import pyuff

    common = dict(binary=0, id2=f"labjoint run {run.name}"[:80], id3=frf.method[:80], id5="",
                  ver_num=0, load_case_id=0, rsp_ent_name="joint", rsp_node=DISPLACEMENT_NODE,
                  rsp_dir=1, ref_ent_name="force", ref_node=FORCE_NODE, ref_dir=1,
                  num_pts=int(frf.freq_hz.size), abscissa_spacing=0,
                  abscissa_min=float(frf.freq_hz[0]), abscissa_inc=0.0, z_axis_value=0.0,
                  **_axes("abscissa", FREQUENCY), **_axes("orddenom", EXCITATION_FORCE),
                  **_axes("z_axis", GENERAL), x=np.asarray(frf.freq_hz, dtype=float))
    h = pyuff.prepare_58(id1=f"{run.name} FRF displacement/force"[:80], id4="receptance H1",
                         func_type=4, ord_data_type=6, **_axes("ordinate", DISPLACEMENT),
                         data=np.asarray(frf.h, dtype=complex), **common)
    coh = pyuff.prepare_58(id1=f"{run.name} coherence"[:80], id4="coherence", func_type=6,
                           ord_data_type=4, **_axes("ordinate", GENERAL),
                           data=np.asarray(frf.coherence, dtype=float),
                           **{**common, **_axes("orddenom", GENERAL)})
    return [h, coh]


def export_uff(run: Run, path: str | Path, *, frf: bool = True) -> dict[str, Any]:
    """Write ``run`` to ``path`` (module docstring); returns what was written."""
    import pyuff

    p = Path(path)
    if p.suffix.lower() not in (".uff", ".unv"):
        raise InputError("a universal file is named *.uff or *.unv", file=str(p))
    if not p.parent.is_dir():
        raise InputError("no such directory", file=str(p.parent))
    sets = [_time_set(run, "displacement", run.displacement, DISPLACEMENT_NODE, DISPLACEMENT),
            _time_set(run, "force", run.force, FORCE_NODE, EXCITATION_FORCE)]
    est = None
    if frf:
        est = frf_h1(run.force, run.displacement - np.mean(run.displacement), run.sample_rate_hz)
        sets += _frf_sets(run, est)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp")
    try:
        pyuff.UFF(str(tmp)).write_sets(sets, mode="overwrite")
        tmp.replace(p)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return {"file": str(p), "datasets": len(sets), "samples": int(run.force.size),
            "frf_lines": None if est is None else int(est.freq_hz.size),
            "frf_method": None if est is None else est.method}
