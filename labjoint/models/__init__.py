"""Joint models: the effects of the vocabulary, their sums, and fitting them to runs.

Typical use (see each module for details)::

    from labjoint.models import Model, ModelFitter, RunData
    runs = [RunData.from_run(run, steady=mask) for run, mask in ...]
    model = Model.parse("linear_stiffness+iwan")
    result = ModelFitter(model).fit(fit_runs, validation=val_runs)
    F = model.eval(result.params_, runs[0])
    richer = ModelFitter(model + "viscous").fit(fit_runs, init=result)   # warm start
"""

from labjoint.models.composition import Model
from labjoint.models.effects import REGISTRY, get_effect
from labjoint.models.effects.base import (
    Effect,
    ForceEffect,
    HystereticEffect,
    InputEffect,
    ModifierEffect,
    SlipModifiers,
)
from labjoint.models.fit import ModelFitter
from labjoint.models.scores import nrmse, nrmse_from_sums, pooled_nrmse
from labjoint.models.inputs import ModelInputs, RunData, derivatives, estimate_frequency
from labjoint.models.params import Parameter, Parameters
from labjoint.models.result import FitResult
from labjoint.models.summary import LoopSummary, RunLoop, period_shift_floor

__all__ = [
    "Model", "ModelFitter", "FitResult", "nrmse", "nrmse_from_sums", "pooled_nrmse", "ModelInputs", "RunData",
    "derivatives", "estimate_frequency", "Parameter", "Parameters", "LoopSummary", "RunLoop",
    "period_shift_floor",
    "REGISTRY", "get_effect", "Effect", "ForceEffect", "HystereticEffect", "InputEffect",
    "ModifierEffect", "SlipModifiers",
]
