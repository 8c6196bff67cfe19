"""Channel delay: the force channel lags the displacement channel by tau."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects.base import InputEffect
from labjoint.models.inputs import ModelInputs, shift
from labjoint.models.summary import LoopSummary


class ChannelDelay(InputEffect):
    """F_measured(t) = F(t - tau): the model is evaluated on u(t - tau)."""

    name = "channel_delay"
    order = 0
    needs_multistart = True
    description = (
        "The force and displacement channels are not simultaneous: different sensor and "
        "amplifier bandwidths, anti-alias filters or a multiplexed DAQ delay one against the "
        "other by tau. The measured force is the joint force at t - tau, so the model is "
        "evaluated on the displacement history delayed by tau (fractional samples allowed).")
    signature = (
        "A spurious loop: the apparent loss changes by pi F U sin(omega tau) (a purely "
        "elastic joint shows area -pi F U sin(omega tau): a lagging force hides loss, a "
        "leading one adds it), growing in proportion to frequency like viscous loss; the "
        "phase of harmonic h shifts by h omega tau.")

    def transform(self, params: Mapping[str, float], inputs: ModelInputs) -> ModelInputs:
        s = float(params["tau"]) * inputs.fs
        if s == 0.0:
            return inputs
        return inputs.with_history(shift(inputs.u_hist, s), shift(inputs.v_hist, s),
                                   shift(inputs.a_hist, s))

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        # the loss a delay fakes cannot be told from real loss in one loop: start at none
        return {"tau": 0.0}

    def neutral(self, summary: LoopSummary) -> dict[str, float]:
        return {"tau": 0.0}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        f_max = max(r.frequency_hz for r in summary.runs)
        return {"tau": 0.02 / f_max}
