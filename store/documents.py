"""The study document (docs/studies.md): what a client submits, what the store keeps and what
the driver reads. Structure is checked here (types, enums, sizes); what depends on the scene
(field names, ranges against the scene's own bounds, design sizes) is checked by the API
(:mod:`service.studies`), which raises :class:`solver.scene.SceneError` naming the dotted field
of every problem.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, Strict, model_validator

from solver.result import METRICS

Metric = Literal[METRICS]  # type: ignore[valid-type]
Number = Annotated[float, Strict()]  # an int or a float; a boolean is not a number
Int = Annotated[int, Strict()]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class ParameterSpec(_Strict):
    """Either explicit ``values`` or a range ``low``..``high`` (optionally ``log`` and ``step``)."""

    values: list[float | int | str | bool] | None = Field(None, min_length=1, max_length=1000)
    low: Number | None = None
    high: Number | None = None
    log: bool = False
    step: Number | None = Field(None, gt=0)

    @model_validator(mode="after")
    def _one_form(self) -> "ParameterSpec":
        if self.values is not None:
            if self.low is not None or self.high is not None:
                raise ValueError("give either values or low/high, not both")
            return self
        if self.low is None or self.high is None:
            raise ValueError("give values: [...] or both low and high")
        if not self.low < self.high:
            raise ValueError(f"low ({self.low:g}) must be below high ({self.high:g})")
        if self.log and self.low <= 0:
            raise ValueError(f"log: true needs low > 0 (got {self.low:g})")
        if self.log and self.step is not None:
            raise ValueError("log and step cannot be combined")
        return self


class Objective(_Strict):
    metric: Metric
    direction: Literal["minimize", "maximize"] = "minimize"


class Constraint(_Strict):
    metric: Metric
    op: Literal["<=", ">="]
    value: Number


class ConfirmSpec(_Strict):
    """Re-run the best trials with more replicas, at another fidelity and/or scene; the ranking
    after confirmation is what the study reports."""

    top_k: int = Field(3, ge=1, le=50, description="how many of the best trials (or sweep points) to confirm")
    replicas: int = Field(4, ge=1, le=100, description="replicas of every confirmed trial")
    fidelity: str | None = Field(None, max_length=20, description="fidelity of the confirmation runs (default: the study's)")
    scene: str | dict[str, Any] | None = Field(None, description="scene of the confirmation runs (default: the study's); the trial's parameters and the study's fixed fields are applied to it")
    fixed: dict[str, Any] = Field(default_factory=dict, description="further dotted overrides for the confirmation runs")


class ScreenSpec(_Strict):
    """Screen, then refine: search the whole parameter ranges on a cheap fidelity first, then run
    the study's own fidelity only inside the box around the screening's best trials."""

    fidelity: str = Field("analytic", max_length=20, description="fidelity of the screening runs")
    n_trials: int = Field(200, ge=2, le=100000, description="screening trials (one run each)")
    top_k: int = Field(10, ge=1, le=1000, description="the screening's best trials that span the refinement box")
    margin: float = Field(0.1, ge=0, le=1, description="widen the box on each side by this fraction of the parameter's full range")
    parallelism: int = Field(16, ge=1, le=100000, description="screening trials in flight at once")


class Measurement(_Strict):
    """One measured point of a calibration: the scene fields that differ from the study's scene
    (set), the measured forces and their standard uncertainties."""

    set: dict[str, Any] = Field(default_factory=dict, description="dotted scene fields of this measurement, e.g. tool.rake_angle_deg")
    cutting_force_N_per_mm: Number | None = None
    thrust_force_N_per_mm: Number | None = None
    sd_N_per_mm: Number | None = Field(None, gt=0, description="standard uncertainty of both forces")
    cutting_force_sd_N_per_mm: Number | None = Field(None, gt=0, description="standard uncertainty of the cutting force (overrides sd_N_per_mm)")
    thrust_force_sd_N_per_mm: Number | None = Field(None, gt=0, description="standard uncertainty of the thrust force (overrides sd_N_per_mm)")
    label: str | None = Field(None, max_length=200)

    @model_validator(mode="after")
    def _forces_and_uncertainties(self) -> "Measurement":
        if self.cutting_force_N_per_mm is None and self.thrust_force_N_per_mm is None:
            raise ValueError("give cutting_force_N_per_mm and/or thrust_force_N_per_mm")
        for force in ("cutting_force", "thrust_force"):
            if getattr(self, f"{force}_N_per_mm") is not None and getattr(self, f"{force}_sd_N_per_mm") is None and self.sd_N_per_mm is None:
                raise ValueError(f"{force}_N_per_mm needs its uncertainty: sd_N_per_mm or {force}_sd_N_per_mm (> 0)")
        return self

    def sd(self, force: str) -> float | None:
        return getattr(self, f"{force}_sd_N_per_mm") or self.sd_N_per_mm


class StudyIn(_Strict):
    """A study document (YAML for the CLI, JSON for REST)."""

    name: str = Field(..., min_length=1, max_length=200, pattern=r"^[\w .:+=,()/-]+$")
    kind: Literal["sweep", "optimize", "convergence", "calibrate"]
    scene: str | dict[str, Any] = Field(..., description="a built-in scene name or an inline scene object")
    fixed: dict[str, Any] = Field(default_factory=dict, description="dotted overrides applied to every job")
    parameters: dict[str, ParameterSpec] = Field(default_factory=dict)
    design: Literal["grid", "lhs", "sobol"] = "grid"
    n_points: Int | None = Field(None, ge=1, le=100000, description="points of an lhs or sobol design")
    sampler: Literal["tpe", "cmaes", "gp", "nsga2"] = "tpe"
    n_trials: Int | None = Field(None, ge=1, le=100000)
    parallelism: Int = Field(4, ge=1, le=100000, description="optimize: trials in flight at once")
    objectives: list[Objective] = Field(default_factory=list, max_length=16)
    constraints: list[Constraint] = Field(default_factory=list, max_length=64)
    seed: Int | None = Field(None, ge=0, le=2**31 - 1)
    max_attempts: Int = Field(3, ge=1, le=20, description="claims of a job before it fails (lost workers)")
    replicas: Int = Field(1, ge=1, le=100, description=(
        "runs per sweep point, optimisation trial, calibration point or convergence level, the k-th "
        "(k = 0 .. replicas-1) with numerics.speed_scaling multiplied by 1 + k 1e-6 (physically nothing); "
        "cutting with fracture is chaotic, so the study compares means and reports their standard errors"))
    confirm: ConfirmSpec | None = Field(None, description="sweep and optimize: re-run the best trials with more replicas, at another fidelity or scene")
    screen: ScreenSpec | None = Field(None, description="optimize and calibrate: screen on a cheap fidelity, then refine in the box around its best trials")
    measurements: list[Measurement] = Field(default_factory=list, max_length=500, description="calibrate: the measured points")
    measurements_csv: str | None = Field(None, max_length=1_000_000, description=(
        "calibrate: the measured points as CSV text (columns: dotted scene fields, cutting_force_N_per_mm, "
        "thrust_force_N_per_mm, sd_N_per_mm or the per-force *_sd_N_per_mm, label); replaces measurements"))
