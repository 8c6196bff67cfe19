"""The fraction done of a model job, from the messages compare sends as it works.

compare reports steps, not fractions: "fitted EXPR" when a diagnosis has fitted its
model, then one message per candidate effect refitted (its name, or "tried NAME"), and,
in a ladder, "step K: ..." when a step ends. The work of a diagnosis is about one unit for
the model's fit and one per candidate; a ladder is at most one diagnosis per effect it
can still add (``max_steps`` + 1 when that is given). The fraction only ever grows and
stays below 1 until the job ends.

>>> p = ModelProgress("diagnose", "linear_stiffness", ["viscous", "coulomb"])
>>> p.fraction
0.0
>>> round(p.update("fitted linear_stiffness"), 3), round(p.update("viscous"), 3)
(0.25, 0.5)
"""

from __future__ import annotations

from typing import Sequence

from labjoint.compare.candidates import candidate_effects
from labjoint.errors import InputError
from labjoint.models import Model

#: The fraction reported while the last unit of work (ranking, ablation) runs.
CEILING = 0.95


class ModelProgress:
    """Fraction done of a fit, diagnosis or ladder job, fed compare's messages."""

    def __init__(self, operation: str, model: str, only: Sequence[str] | None = None,
                 max_steps: int | None = None) -> None:
        self.operation = operation
        self.only = list(only) if only is not None else None
        self.fraction = 0.0
        self._step = 0
        self._done = 0
        self._units = self._units_of(model)
        n_steps = len(candidate_effects(Model.parse(model), self.only)[0]) + 1
        self._steps = 1 if operation != "ladder" else (
            min(n_steps, int(max_steps) + 1) if max_steps is not None else n_steps)

    def _units_of(self, expr: str) -> int:
        """Work units of one diagnosis of ``expr``: its fit, each candidate, the rest."""
        try:
            return len(candidate_effects(Model.parse(expr), self.only)[0]) + 2
        except InputError:
            return 2

    def update(self, message: str) -> float:
        """Account for one message; the fraction done."""
        msg = str(message)
        if msg.startswith("fitted "):
            self._units = self._units_of(msg.split()[1])
            self._done = 1
        elif msg.startswith("step "):
            self._step += 1
            self._done = 0
        else:
            self._done += 1
        within = min(self._done / max(self._units, 1), 1.0)
        total = (self._step + within) / max(self._steps, 1)
        self.fraction = max(self.fraction, min(total, CEILING))
        return self.fraction
