"""Model comparison: measured against model, where it fails, which effect is missing, the ladder.

Entry points (each takes run-file or CSV paths, :class:`~labjoint.storage.Run` objects or
prepared runs, and a model expression ``"a+b+c"``):

- :func:`fit` / :func:`fit_runs`: fit, NRMSE (pooled and per run), noise floor, energy-loss
  and stiffness errors; :func:`fit_report` for the richer object;
- :func:`diagnose` / :func:`diagnose_runs`: where the model fails and which effect is
  missing; :func:`diagnose_report` returns the :class:`Diagnosis`;
- :func:`ladder` / :func:`ladder_runs`: successive models until adequate, saved in the run
  files; :func:`load_ladders` reads them back.

Every entry point works on measurements of one kind (:mod:`labjoint.compare.measurement`,
:mod:`labjoint.compare.kinds`): ``kind="sine"`` judges the steady cycles of runs under a
steady sine, ``kind="record"`` judges a record under any excitation along its history,
``kind="auto"`` (default) chooses sine when every run is a steady sine.

Building blocks: :func:`prepare` (any kind), :func:`prepare_runs` (sines),
:func:`noise_floor`, :func:`evaluate`, :func:`residual_maps`, :func:`physics_curves`,
:func:`mean_loops`.
"""

from labjoint.compare.api import (diagnose_report, diagnose_runs, fit_report, fit_runs,
                                  ladder_report, ladder_runs)
from labjoint.compare.curves import PhysicsCurves, mean_loops, physics_curves
from labjoint.compare.diagnosis import CandidateResult, DiagnoseSettings, Diagnosis, diagnose_prepared
from labjoint.compare.ladders import Ladder, LadderStep, build_ladder
from labjoint.compare.metrics import Evaluation, RunEval, evaluate
from labjoint.compare.kinds import KINDS, kind_of, prepare
from labjoint.compare.measurement import Measurement, NoiseFloor, noise_floor
from labjoint.compare.residuals import ResidualMaps, residual_maps
from labjoint.compare.prepared import PreparedRun
from labjoint.compare.runs import prepare_run, prepare_runs
from labjoint.storage import read_any
from labjoint.compare.significance import SignificanceSettings
from labjoint.compare.store import load_ladder, load_ladders, save_ladder

#: the names the REST service calls: ``fn(runs, model, **options) -> dict``
fit = fit_runs
diagnose = diagnose_runs
ladder = ladder_runs

__all__ = [
    "fit", "diagnose", "ladder", "fit_runs", "diagnose_runs", "ladder_runs", "fit_report",
    "diagnose_report", "ladder_report", "load_ladders", "load_ladder", "save_ladder",
    "prepare", "KINDS", "kind_of", "Measurement", "prepare_run", "prepare_runs", "read_any", "PreparedRun", "noise_floor", "NoiseFloor",
    "evaluate", "Evaluation", "RunEval", "residual_maps", "ResidualMaps", "physics_curves",
    "PhysicsCurves", "mean_loops", "diagnose_prepared", "Diagnosis", "DiagnoseSettings",
    "CandidateResult", "SignificanceSettings", "build_ladder", "Ladder", "LadderStep",
]
