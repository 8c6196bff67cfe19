"""Response models of ``GET /trends`` (published in the OpenAPI schema): per-run values
of both identification methods with standard uncertainties, seed 002 Tables 2-4, and
the dissipation-exponent fits (:mod:`labjoint.identify.trends`). SI units throughout."""

from __future__ import annotations

from typing import Any, Optional

from pydantic import BaseModel, ConfigDict, Field

Num = Optional[float]


class TrendRun(BaseModel):
    """One run: the hysteresis loop (measured) and, when the friction coefficient is
    known, the stick-slip boundary (model, prefix ``stickslip_``); ``<key>_uncertainty``
    is the standard uncertainty of the mean over the steady cycles. More fields of
    ``labjoint analyze`` follow."""

    model_config = ConfigDict(extra="allow")

    run: str
    excitation_vpp: Num = None
    torque_nm: Num = None
    frequency_hz: Num = None
    cycles: Optional[int] = None
    displacement_amplitude_m: Num = None
    displacement_amplitude_m_uncertainty: Num = None
    force_amplitude_n: Num = None
    force_amplitude_n_uncertainty: Num = None
    energy_loss_j: Num = None
    energy_loss_j_uncertainty: Num = None
    damping_ns_per_m: Num = None
    damping_ns_per_m_uncertainty: Num = None
    stiffness_n_per_m: Num = None
    stiffness_n_per_m_uncertainty: Num = None
    below_resolution: Optional[bool] = Field(None, description="loop W under twice its "
                                             "uncertainty: not a measurement of W or C")
    stickslip_energy_loss_j: Num = None
    stickslip_energy_loss_j_uncertainty: Num = None
    stickslip_damping_ns_per_m: Num = None
    stickslip_damping_ns_per_m_uncertainty: Num = None
    stickslip_stiffness_n_per_m: Num = None
    stickslip_stiffness_n_per_m_uncertainty: Num = None
    energy_loss_diff_pct: Num = None
    damping_diff_pct: Num = None
    stiffness_diff_pct: Num = None


class TrendError(BaseModel):
    run: str
    error: str


class TableRow(BaseModel):
    """A line of seed 002 Tables 2-4: one property of one run by both methods."""

    run: str
    condition: dict[str, Num] = Field(description="the varying conditions' values")
    property: str = Field(description="energy_loss_j, damping_ns_per_m or stiffness_n_per_m")
    label: str
    unit: str = Field(description="SI unit of the values")
    stickslip: Num = None
    stickslip_uncertainty: Num = None
    loop: Num = None
    loop_uncertainty: Num = None
    below_resolution: bool = False
    diff_pct: Num = Field(None, description="(loop - stick-slip) / loop in %")


class TrendTable(BaseModel):
    conditions: list[str] = Field(description="excitation_vpp and/or torque_nm when they "
                                  "vary (Tables 3, 4); empty: one row per run (Table 2)")
    rows: list[TableRow]
    note: str


class ExponentFit(BaseModel):
    """W = coefficient x^exponent by weighted least squares on log axes (seed 001:
    Segalman W ~ F^(3 + chi)); ``error`` says why there is no fit (fewer than 3
    distinct amplitudes, no usable W)."""

    method: str = Field(description="loop or stickslip")
    quantity: str
    against: str = Field(description="the amplitude: excitation_vpp, "
                         "displacement_amplitude_m or force_amplitude_n")
    runs: list[str] = Field(description="runs in the fit")
    excluded: list[str] = Field(description="runs left out (W not a measurement)")
    error: Optional[str] = None
    exponent: Num = None
    exponent_stderr: Num = None
    exponent_ci95: Optional[list[float]] = None
    coefficient: Num = None
    n_points: Optional[int] = None
    n_amplitudes: Optional[int] = None
    dof: Optional[int] = None
    chi2_reduced: Num = None
    weighted: Optional[bool] = None
    reference: Optional[str] = None


class TrendAxis(BaseModel):
    label: str
    unit: str
    power_law: bool = Field(description="W is a power law of it: plotted on log axes")


class TrendSelection(BaseModel):
    runs: list[str] = Field(description="the runs asked for, in the order analysed")
    truncated: bool = Field(description="more runs match the filter than `limit`")


class Trends(BaseModel):
    """The trends of a set of runs."""

    selection: TrendSelection
    runs: list[TrendRun]
    errors: list[TrendError]
    methods: list[str]
    varying: list[str]
    axes: dict[str, TrendAxis]
    table: TrendTable
    fit: ExponentFit = Field(description="loop W against force amplitude: the dissipation "
                             "exponent")
    fits: list[ExponentFit] = Field(description="each method's W against each amplitude")
    series_fits: list[dict[str, Any]] = Field(
        default_factory=list, description="the main fit (loop W against force amplitude) of "
        "each series, one frequency and one bolt torque, with its frequency_hz and torque_nm, "
        "when the runs hold several (one exponent is refused across them)")
    notes: list[str]
