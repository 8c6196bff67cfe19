"""A joint's tangential law: any effect expression of :mod:`labjoint.models`, evaluated
along a displacement history with its hysteretic state (the one source of the laws).

Two uses: the steady periodic force for harmonic balance (alternating frequency-time,
AFT) and the force after one more time step for time integration. Both go through
:meth:`labjoint.models.Model.eval` on a history that starts relaxed at u = 0 (the joint
of the assembled structure at rest):

- periodic: the history is u = 0, then ``PRIME_PERIODS`` copies of the period, rotated
  to start at its largest value (so the first step is the virgin loading to the top of
  the loop); the last period is the steady one. For Masing laws (richard_abbott, iwan),
  slider populations (coulomb) and linear terms this is exact after one period (the
  extremes wipe the memory); Bouc-Wen and Valanis settle within the priming.
- stepping: the past is kept as its reversal points only (the values of u where the
  direction of motion changed, plus the latest value). Rate-independent laws depend on
  nothing else, so this is exact for them, and a step costs O(reversals), not O(steps).
  ``channel_delay`` (a time shift between measured channels) has no meaning on such a
  history and is refused there.

>>> law = JointLaw("coulomb", {"coulomb.k": 1e6, "coulomb.f_s": 10.0})
>>> round(law.initial_stiffness() / 1e6, 6)
1.0
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.errors import InputError
from labjoint.models import Model, ModelInputs
from labjoint.models.effects import SlipModifiers
from labjoint.models.effects._steady import steady_batch, steady_tangent, term_matrix
from labjoint.models.effects.base import ElasticEffect

NO_MODIFIERS = SlipModifiers()

PRIME_PERIODS = 3
#: evaluate laws of kernel terms with the batched numba kernels (:mod:`._steady`) and let
#: joints and harmonic balance use their compiled paths; False: the Python path throughout
#: (the benchmark times both in one process)
KERNEL = True
#: effects whose force depends on the rate of the history, not only on its path
RATE_EFFECTS = frozenset({"viscous", "inertia", "channel_delay"})


class JointLaw:
    """Force (N) of an effect expression along slip histories u (m)."""

    def __init__(self, model: str | Model, params: Mapping[str, float], field: str = "joint") -> None:
        try:
            self.model = Model.parse(model)
        except InputError as exc:
            raise InputError(exc.message, field=f"{field}.model") from None
        missing = [p for p in self.model.param_names if p not in params]
        if missing:
            raise InputError(f"law '{self.model.expr}' needs {', '.join(missing)}",
                             field=f"{field}.params")
        unknown = [p for p in params if p not in self.model.param_names]
        if unknown:
            raise InputError(f"not parameters of '{self.model.expr}': {', '.join(unknown)}; "
                             f"known: {', '.join(self.model.param_names)}", field=f"{field}.params")
        self.params = {k: float(params[k]) for k in self.model.param_names}
        try:
            self.model.values(self.params)
        except InputError as exc:
            raise InputError(exc.message, field=f"{field}.params.{exc.field}") from None
        self.rate_dependent = bool(RATE_EFFECTS & set(self.model.names))
        self._free, self._mem = self._split()
        # a memory part of hysteretic effects alone (no modifier, no input effect) is the
        # sum of their simulations along u: Model.eval's own path for it, without its
        # per-call bookkeeping (issue 32: that bookkeeping was 3/4 of a diagnosis's time)
        self._vals = self.model.values(self.params)
        self._direct = all(e.kind == "hysteretic" for e in self.model.effects)
        self._memoryless = all(e.kind in ("force", "elastic") for e in self.model.effects)
        # a law whose every effect is a term of the batched kernel (no modifier, no input
        # effect): the whole batch of histories in one numba call (issue 32 item 6)
        plain = all(e.kind in ("force", "elastic", "hysteretic") for e in self.model.effects)
        terms = [e.steady_term(self._vals[e.name]) for e in self.model.effects] if plain else [None]
        self._terms = term_matrix(terms) if KERNEL and all(t is not None for t in terms) else None

    @property
    def kernel_terms(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(codes, parameter matrix) of the batched steady-state kernel, or None if some
        effect of the law has no kernel term (:mod:`labjoint.models.effects._steady`)."""
        return self._terms

    def _split(self) -> tuple[JointLaw | None, JointLaw | None]:
        """The memoryless part (force effects, evaluated for a whole batch of histories in
        one call) and the part with memory (hysteretic effects and what modifies them,
        one history at a time); None for an empty part. With an input effect (a gap, a
        delay) every term sees the transformed history, so nothing is split off."""
        kinds = {e.kind for e in self.model.effects}
        free = [e.name for e in self.model.effects if e.kind == "force"]
        if "input" in kinds or not free or len(free) == len(self.model.effects):
            return None, None
        mem = [e.name for e in self.model.effects if e.kind != "force"]
        part = lambda names: JointLaw("+".join(names), {k: v for k, v in self.params.items()  # noqa: E731
                                                        if k.split(".")[0] in names})
        return part(free), part(mem)

    def with_params(self, **changes: float) -> JointLaw:
        """A copy with some parameters changed."""
        p = dict(self.params)
        p.update({k: float(v) for k, v in changes.items()})
        return JointLaw(self.model, p)

    def _eval(self, u: np.ndarray, v: np.ndarray, a: np.ndarray, fs: float, n_prime: int) -> np.ndarray:
        inp = ModelInputs(u, v, a, fs, n_prime)
        return self.model.eval(self.params, inp)

    # -- harmonic balance -----------------------------------------------------------------
    def periodic(self, u: np.ndarray, v: np.ndarray, a: np.ndarray, fs: float) -> np.ndarray:
        """Steady force over one period sampled uniformly at ``fs`` (module docstring).

        ``u``, ``v``, ``a`` may be 2-D (batch, samples): each row is a separate history.
        """
        u, v, a = (np.atleast_2d(np.asarray(x, float)) for x in (u, v, a))
        rows, n = u.shape
        if self._terms is not None:
            return steady_batch(u, v, a, self._terms[0], self._terms[1], PRIME_PERIODS)
        if self._free is not None:
            return self._free.periodic(u, v, a, fs) + self._mem.periodic(u, v, a, fs)
        if self._memoryless:                       # every term elementwise: one pass
            return self._elementwise(u, v, a, fs)
        # every row started at its maximum (index arithmetic for the whole batch at once:
        # a roll and a tile per row had cost more than the law itself)
        i0 = np.argmax(u, axis=1)
        idx = (np.arange(n)[None, :] + i0[:, None]) % n
        r = np.arange(rows)[:, None]
        hist = [np.concatenate([np.zeros((rows, 1)), np.tile(x[r, idx], PRIME_PERIODS)], axis=1)
                for x in (u, v, a)]
        out = np.empty_like(u)
        n_prime = 1 + (PRIME_PERIODS - 1) * n
        for k in range(rows):
            if self._direct:
                f = sum(e.simulate(self._vals[e.name], hist[0][k], NO_MODIFIERS)[0]
                        for e in self.model.effects)
                out[k, idx[k]] = f[n_prime:]
            else:
                out[k, idx[k]] = self._eval(hist[0][k], hist[1][k], hist[2][k], fs, n_prime)
        return out

    def periodic_tangent(self, u: np.ndarray, v: np.ndarray, a: np.ndarray, fs: float,
                         s: np.ndarray, T: tuple[np.ndarray, np.ndarray, np.ndarray],
                         h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`periodic` (rows, n) and its derivative (rows, n, m) in each row's period
        coefficients c, where row r's u, v, a are s[r] T_u c, s[r] T_v c, s[r] T_a c (T: n x m).
        Exact (forward mode, :func:`steady_tangent`) for a memory part of slider and Masing
        laws; otherwise forward differences of step h[r] in c, every coefficient in one batch."""
        u, v, a = (np.atleast_2d(np.asarray(x, float)) for x in (u, v, a))
        if self._terms is not None:
            return steady_tangent(u, v, a, np.asarray(s, float), T[0], T[1], T[2], self._terms[0],
                                  self._terms[1], PRIME_PERIODS)
        if self._free is not None:
            F1, d1 = self._free.periodic_tangent(u, v, a, fs, s, T, h)
            F2, d2 = self._mem.periodic_tangent(u, v, a, fs, s, T, h)
            return F1 + F2, d1 + d2
        rows, n = u.shape
        m = T[0].shape[1]
        if self._memoryless:        # elementwise: chain rule through dF/du, dF/dv, dF/da
            F = self._elementwise(u, v, a, fs)
            dF = np.zeros((rows, n, m))
            x = [u, v, a]
            for i, Tx in enumerate(T):
                d = np.abs(np.asarray(s, float) * h) * max(float(np.max(np.abs(Tx))), 1e-300)
                if not np.any(Tx):
                    continue
                xp = list(x)
                xp[i] = x[i] + d[:, None]
                slope = (self._elementwise(*xp, fs) - F) / d[:, None]
                dF += slope[:, :, None] * (np.asarray(s, float)[:, None, None] * Tx[None])
            return F, dF
        step = (np.asarray(s, float) * h)[:, None, None]
        pert = [np.concatenate([x[:, None, :], x[:, None, :] + step * Tx.T[None]], axis=1).reshape(-1, n)
                for x, Tx in zip((u, v, a), T)]
        Fb = self.periodic(*pert, fs).reshape(rows, m + 1, n)
        return Fb[:, 0], ((Fb[:, 1:] - Fb[:, :1]) / h[:, None, None]).transpose(0, 2, 1)

    def _elementwise(self, u: np.ndarray, v: np.ndarray, a: np.ndarray, fs: float) -> np.ndarray:
        """A law of force and elastic effects on arrays of any shape: the sum
        :meth:`Model.eval` makes, term by term in the model's order, with the values
        checked once at construction."""
        inp = ModelInputs(u, v, a, fs, 0)
        total = np.zeros(u.shape)
        for e in self.model.effects:
            p = self._vals[e.name]
            total += e.elastic(p, u) if isinstance(e, ElasticEffect) else p[e.param_names[0]] * e.basis(inp)
        return total

    def initial_stiffness(self, du: float = 1e-12) -> float:
        """Tangent stiffness (N/m) at rest: the joint's linear (stuck) stiffness."""
        z = np.zeros(2)
        f = self._eval(np.array([0.0, du]), z, z, 1.0, 1)
        return float(f[-1] / du)

    # -- time stepping --------------------------------------------------------------------
    def check_steppable(self) -> None:
        if "channel_delay" in self.model.names:
            raise InputError("time integration of a joint cannot apply channel_delay (a shift "
                             "between measured channels, not a joint force)", field="joint.model")

    def step_force(self, reversals: np.ndarray, u: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Force at each trial value ``u`` (with rates v, a) after the past ``reversals``."""
        u = np.atleast_1d(np.asarray(u, float))
        out = np.empty(u.size)
        m = reversals.size
        z = np.zeros(m + 1)
        for i in range(u.size):
            hist = np.append(reversals, u[i])
            vv, aa = z.copy(), z.copy()
            vv[-1], aa[-1] = v[i], a[i]
            out[i] = self._eval(hist, vv, aa, 1.0, m)[0]
        return out


def push_reversal(reversals: list[float], u: float) -> None:
    """Append u to a reversal list (starting at [0.0]): a move in the same direction as the
    last one replaces the last point, a change of direction keeps it."""
    if u == reversals[-1]:
        return
    if len(reversals) >= 2 and (u - reversals[-1]) * (reversals[-1] - reversals[-2]) > 0:
        reversals[-1] = u
    else:
        reversals.append(u)
