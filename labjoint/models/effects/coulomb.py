"""One Jenkins element: a spring k in series with a Coulomb slider of strength f_s."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects._population import population_force
from labjoint.models.effects._steady import JENKINS, NONE
from labjoint.models.effects.base import NO_MODIFIERS, HystereticEffect, SlipModifiers
from labjoint.models.summary import LoopSummary


class Coulomb(HystereticEffect):
    """Jenkins element: sticks with stiffness k, slides at |F| = f_s (macro-slip only)."""

    name = "coulomb"
    log_params = frozenset({"k", "f_s"})
    description = (
        "The whole contact sticks or slides at once: a tangential spring k (contact "
        "compliance) in series with a Coulomb slider that slips when the force reaches "
        "f_s = mu N. It is the Jenkins element, the building block of Iwan and Masing "
        "models (seed 001), and the simplest model of gross (macro) slip.")
    signature = (
        "Parallelogram loop with a flat plateau at +-f_s; per cycle of amplitude U > f_s/k "
        "it dissipates 4 f_s (U - f_s/k), growing linearly with amplitude, none below "
        "f_s/k; stiffness falls abruptly at slip; odd harmonics; independent of frequency.")

    def simulate(self, params: Mapping[str, float], u: np.ndarray,
                 modifiers: SlipModifiers = NO_MODIFIERS,
                 e_other: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        k = float(params["k"])
        if k <= 0:
            return np.zeros_like(u), np.zeros_like(u)
        e = np.zeros_like(u) if e_other is None else e_other
        return population_force(u, np.array([k]), np.array([float(params["f_s"])]), 0.0,
                                modifiers.asym, modifiers.inv_ew, e)

    def steady_term(self, params: Mapping[str, float]) -> tuple[int, np.ndarray]:
        k = float(params["k"])
        if k <= 0:
            return NONE, np.zeros(0)
        return JENKINS, np.array([k, float(params["f_s"])])

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        k = summary.k_stick
        return {"k": k, "f_s": summary.jenkins_strength(k)}
