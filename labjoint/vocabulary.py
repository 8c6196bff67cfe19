"""The effect vocabulary of design.md: names, parameters, units and the defining law.

This is data only, shared by the simulator (which injects effects into the simulated
joint) and the model layer (which fits them); each implements the law independently.
Displacement ``u`` is the relative tangential displacement across the joint (m),
force ``F`` the tangential joint force (N), positive in the same direction.

Canonical laws (SI):

- ``linear_stiffness``: F = k u.
- ``viscous``: F = c du/dt.
- ``coulomb``: one Jenkins element, a spring k in series with a Coulomb slider of
  strength f_s; per cycle of amplitude U > f_s/k it dissipates 4 f_s (U - f_s/k).
- ``iwan``: Segalman's 4-parameter parallel Iwan (F_S, K_T, chi, beta): slider-strength
  density rho(phi) = R phi^chi on (0, phi_max) plus S delta(phi - phi_max), with
  phi_max = F_S (1 + beta) / (K_T (beta + (chi + 1)/(chi + 2))),
  R = F_S (chi + 1) / (phi_max^(chi + 2) (beta + (chi + 1)/(chi + 2))),
  S = (F_S / phi_max) (beta / (beta + (chi + 1)/(chi + 2))).
  F_S is the macro-slip force, K_T the initial stiffness; micro-slip dissipation
  grows like U^(3 + chi) (seed 001).
- ``bouc_wen``: F = z, dz/dt = k0 du/dt - alpha |du/dt| |z|^(n-1) z - beta du/dt |z|^n
  (seed 001's classical form, A = k0; alpha + beta > 0 saturates z at
  (k0 / (alpha + beta))^(1/n), alpha + beta < 0 hardens it).
- ``valanis``: seed 001 (Lenz and Gaul): dF/dt = E0 du/dt [1 + (lam/E0) sgn(du/dt)(Et u - F)]
  / [1 + kappa (lam/E0) sgn(du/dt)(Et u - F)].
- ``richard_abbott``: backbone (seed 000 Eq. 2 with stress -> force, strain -> displacement)
  g(u) = (ke - kp) u / (1 + |(ke - kp) u / F_y|^n)^(1/n) + kp u; Masing branches
  F = F_r + 2 g((u - u_r)/2) from the last reversal (u_r, F_r).
- ``cubic_stiffness``: F = k3 u^3.
- ``quadratic_stiffness``: F = k2 u^2 (even: F(-u) != -F(u)); beside linear_stiffness k the
  secant stiffness at +-U is k +- k2 U, so k2 > 0 makes the +u side stiffer.
- ``bilinear_stiffness``: F = dk max(u, 0): beside linear_stiffness k the joint is k_minus = k
  for u < 0 and k_plus = k + dk for u > 0 (dk > 0: the +u side is stiffer).
- ``contact``: a one-sided contact across a gap g >= 0 from rest, stiffness |k_c|, on the
  side given by the sign of k_c: F = k_c max(sgn(k_c) u - g, 0) (k_c > 0: it closes at
  u = +g and pushes back for u > g; k_c < 0: it closes at u = -g). Not ``backlash``: that
  is a symmetric gap in series with the whole joint, this is a force in parallel on one side.
- ``saturating_stiffness``: F = k_s x_s tanh(u / x_s) (odd, memoryless, no loss): beside
  linear_stiffness k the joint is k + k_s at |u| << x_s and levels off to k beyond x_s
  (k_s > 0 softens, k_s < 0 stiffens); describing function k + k_s D(U / x_s),
  D(a) = (2 / (pi a)) int_0^pi tanh(a sin t) sin t dt.
- ``offset``: F = F0.
- ``asymmetric_slip``: every slip strength of the hysteretic part is scaled by (1 + asym)
  while sliding in +u and by (1 - asym) while sliding in -u.
- ``inertia``: F = m d2u/dt2 (mass between the force sensor and the interface).
- ``wear``: every slip strength of the hysteretic part is scaled by exp(-E_d / E_w),
  E_d the energy dissipated by the joint since the record (simulation) began.
- ``backlash``: a gap of total width g centred on u = 0: the joint's elastic and
  hysteretic parts see u_eff = sign(u) max(|u| - g/2, 0) (viscous sees d u_eff/dt).
- ``channel_delay``: the force channel lags the displacement channel by tau:
  F_measured(t) = F(t - tau).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ParamSpec:
    name: str
    unit: str
    lower: float
    upper: float
    description: str


@dataclass(frozen=True)
class EffectSpec:
    name: str
    kind: str  # "force" (adds a force linear in its one parameter), "elastic" (adds a
    #            memoryless force nonlinear in its parameters), "hysteretic" (adds a
    #            history-dependent force), "modifier" (scales the hysteretic part's slip
    #            strengths), "input" (transforms u or t)
    params: tuple[ParamSpec, ...]


INF = float("inf")

EFFECTS: dict[str, EffectSpec] = {
    e.name: e
    for e in (
        EffectSpec("linear_stiffness", "force", (ParamSpec("k", "N/m", -INF, INF, "stiffness"),)),
        EffectSpec("viscous", "force", (ParamSpec("c", "N s/m", 0.0, INF, "viscous damping"),)),
        EffectSpec("coulomb", "hysteretic", (
            ParamSpec("k", "N/m", 0.0, INF, "spring in series with the slider"),
            ParamSpec("f_s", "N", 0.0, INF, "slip force of the slider"))),
        EffectSpec("iwan", "hysteretic", (
            ParamSpec("F_S", "N", 0.0, INF, "macro-slip force"),
            ParamSpec("K_T", "N/m", 0.0, INF, "initial tangential stiffness"),
            ParamSpec("chi", "1", -1.0, 1.0, "power-law exponent of the slider density"),
            ParamSpec("beta", "1", 0.0, INF, "weight of the macro-slip delta"))),
        EffectSpec("bouc_wen", "hysteretic", (
            ParamSpec("k0", "N/m", 0.0, INF, "initial stiffness (A)"),
            ParamSpec("alpha", "N^(1-n)/m", -INF, INF, "|du| |z|^(n-1) z coefficient"),
            ParamSpec("beta", "N^(1-n)/m", -INF, INF, "du |z|^n coefficient"),
            ParamSpec("n", "1", 0.2, 20.0, "sharpness"))),
        EffectSpec("valanis", "hysteretic", (
            ParamSpec("E0", "N/m", 0.0, INF, "initial stiffness"),
            ParamSpec("Et", "N/m", 0.0, INF, "tangent stiffness in slip"),
            ParamSpec("lam", "1/m", 0.0, INF, "lambda"),
            ParamSpec("kappa", "1", 0.0, 1.0, "kappa"))),
        EffectSpec("richard_abbott", "hysteretic", (
            ParamSpec("ke", "N/m", 0.0, INF, "sticking elastic stiffness"),
            ParamSpec("kp", "N/m", 0.0, INF, "sliding plastic stiffness"),
            ParamSpec("F_y", "N", 0.0, INF, "yield force"),
            ParamSpec("n", "1", 0.1, 100.0, "shape factor"))),
        EffectSpec("cubic_stiffness", "force", (ParamSpec("k3", "N/m^3", -INF, INF, "cubic stiffness"),)),
        EffectSpec("quadratic_stiffness", "force", (
            ParamSpec("k2", "N/m^2", -INF, INF, "quadratic (even) stiffness: > 0 stiffer on the +u side"),)),
        EffectSpec("bilinear_stiffness", "force", (
            ParamSpec("dk", "N/m", -INF, INF, "stiffness added for u > 0: > 0 the +u side is stiffer"),)),
        EffectSpec("contact", "elastic", (
            ParamSpec("k_c", "N/m", -INF, INF, "contact stiffness; its sign is the side (> 0: +u)"),
            ParamSpec("gap", "m", 0.0, INF, "travel from rest until the contact closes"))),
        EffectSpec("saturating_stiffness", "elastic", (
            ParamSpec("k_s", "N/m", -INF, INF,
                      "stiffness added at |u| << x_s, saturating beyond (> 0: softening)"),
            ParamSpec("x_s", "m", 0.0, INF, "displacement where it levels off (> 0)"))),
        EffectSpec("offset", "force", (ParamSpec("F0", "N", -INF, INF, "constant force"),)),
        EffectSpec("asymmetric_slip", "modifier", (
            ParamSpec("asym", "1", -0.95, 0.95, "relative slip-strength difference + vs -"),)),
        EffectSpec("inertia", "force", (ParamSpec("m", "kg", -INF, INF, "mass between sensor and interface"),)),
        EffectSpec("wear", "modifier", (ParamSpec("E_w", "J", 0.0, INF, "dissipated energy per e-fold of slip strength"),)),
        EffectSpec("backlash", "input", (ParamSpec("gap", "m", 0.0, INF, "total gap width"),)),
        EffectSpec("channel_delay", "input", (ParamSpec("tau", "s", -INF, INF, "force lags displacement by tau"),)),
    )
}

HYSTERETIC = tuple(n for n, e in EFFECTS.items() if e.kind == "hysteretic")
