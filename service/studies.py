"""Studies: validation of a study document against the scene schema and the limits, and its
creation (the study row, its jobs, its optuna study) through the store.

- ``sweep``: a grid, Latin hypercube or Sobol design over dotted scene fields; all jobs at once.
- ``convergence``: the same scene at several ``numerics.element_size_um`` and/or mass/speed
  scaling levels (a grid); every level is a job whose metrics and wall time are stored, and the
  trials carry their relative error against the finest level.
- ``optimize`` and ``calibrate``: the trials come from optuna, asked by the driver
  (:mod:`store.studies`) as jobs finish.
"""

from __future__ import annotations

import logging
import os
from typing import Any

from solver.catalogue import CATALOGUE
from solver.scene import Problem, SceneError, _field_info, scene_from_dict
from store import NewJob, Store, calibration
from store.documents import StudyIn
from store.studies import _base_scene, build_scene, scene_hash, stage_scene

from . import designs
from .config import Limits
from .inputs import bool_problems

log = logging.getLogger("fibrecut.studies")
CONVERGENCE_FIELDS = ("numerics.element_size_um", "numerics.mass_scaling", "numerics.speed_scaling")


def validate(doc: StudyIn, limits: Limits) -> tuple[dict, list[dict[str, Any]]]:
    """Check a study document against the scene schema and the limits.

    Returns the base scene dict (with ``fixed`` applied) and, for sweeps and convergence
    studies, the list of design points. Raises :class:`SceneError`.
    """
    problems: list[Problem] = []
    base = _base_scene(doc)
    for name in doc.fixed:
        if _field_info(name.split(".")) is None:
            problems.append(Problem(("fixed", name), doc.fixed[name], "unknown scene field (use dotted names such as tool.rake_angle_deg)"))
    problems += [Problem(("fixed", f), v, m) for f, v, m in bool_problems(doc.fixed)]
    if isinstance(doc.scene, dict):
        problems += [Problem(("scene", f), v, m) for f, v, m in bool_problems(doc.scene)]
    for name, spec in doc.parameters.items():
        for i, v in enumerate(spec.values or []):
            problems += [Problem(("parameters", name, "values"), v, m) for _, v, m in bool_problems({name: v})]
    if problems:
        raise SceneError(problems)
    base_scene = build_scene(base, doc.fixed)
    base_fixed = base_scene.model_dump(mode="json")

    if len(doc.parameters) > limits.max_parameters:
        problems.append(Problem(("parameters",), len(doc.parameters), f"at most {limits.max_parameters} parameters"))
    if not doc.parameters:
        problems.append(Problem(("parameters",), {}, "give at least one parameter (a dotted scene field with values or low/high)"))
    for name, spec in doc.parameters.items():
        loc = ("parameters", name)
        info = _field_info(name.split("."))
        if info is None:
            problems.append(Problem(loc, name, "unknown scene field (use dotted names such as tool.rake_angle_deg)"))
            continue
        if name in doc.fixed:
            problems.append(Problem(loc, name, "is also in fixed; a field is either fixed or a parameter"))
        if doc.kind == "convergence" and name not in CONVERGENCE_FIELDS:
            problems.append(Problem(loc, name, f"a convergence study varies only {', '.join(CONVERGENCE_FIELDS)}"))
        if spec.values is not None and len(spec.values) > limits.max_values_per_parameter:
            problems.append(Problem(loc + ("values",), len(spec.values), f"at most {limits.max_values_per_parameter} values"))
            continue
        # every given value and both range ends must be valid for this field on the base scene
        checks = [("values", v) for v in spec.values] if spec.values is not None else [("low", spec.low), ("high", spec.high)]
        for key, v in checks:
            try:
                scene_from_dict(base_fixed, {name: v})
            except SceneError as exc:
                for p in exc.problems:
                    msg = p.message if p.field == name else f"makes {p.field} invalid: {p.message}"
                    problems.append(Problem(loc + (key,), v, msg))
                break
    if problems:
        raise SceneError(problems)

    if doc.kind == "calibrate":
        calibration.validate(doc, base_fixed, limits)
    if doc.kind in ("optimize", "calibrate"):
        _validate_optimize(doc, limits)
        _validate_stages(doc, limits)
        _check_job_budget(doc, limits, 0)
        return base_fixed, []
    if doc.constraints:
        problems.append(Problem(("constraints",), "...", "only an optimize study takes constraints"))
    if doc.objectives and doc.kind != "sweep":
        problems.append(Problem(("objectives",), "...", "only optimize and sweep studies take objectives"))
    if doc.measurements or doc.measurements_csv is not None:
        problems.append(Problem(("measurements",), "...", "only a calibrate study takes measurements"))
    if problems:
        raise SceneError(problems)
    _validate_stages(doc, limits)
    design = "grid" if doc.kind == "convergence" else doc.design
    if design == "grid":
        for name, spec in doc.parameters.items():
            if spec.values is None and spec.step is None:
                problems.append(Problem(("parameters", name), {"low": spec.low, "high": spec.high},
                                        "a grid over a range needs step (or give values: [...]); or use design lhs or sobol"))
        if problems:
            raise SceneError(problems)
        size = designs.grid_size(doc.parameters) * doc.replicas
        if doc.confirm is not None:
            size += doc.confirm.top_k * doc.confirm.replicas
        if size > limits.max_jobs_per_study:
            what = f"the grid has {size / doc.replicas:.4g} points x {doc.replicas} replicas" if doc.replicas > 1 else f"the grid has {size:.4g} points"
            raise SceneError([Problem(("parameters",), size, f"{what}; at most {limits.max_jobs_per_study} jobs per study")])
        points = designs.grid(doc.parameters)
    else:
        if doc.n_points is None:
            raise SceneError([Problem(("n_points",), None, f"design {design} needs n_points (1 to {limits.max_jobs_per_study})")])
        if doc.n_points * doc.replicas > limits.max_jobs_per_study:
            raise SceneError([Problem(("n_points",), doc.n_points, f"{doc.n_points} points x {doc.replicas} replicas; at most {limits.max_jobs_per_study} jobs per study")])
        points = designs.sample(doc.parameters, design, doc.n_points, doc.seed)
    return base_fixed, points


def _validate_optimize(doc: StudyIn, limits: Limits) -> None:
    problems = []
    if doc.n_trials is None:
        problems.append(Problem(("n_trials",), None, f"an {doc.kind} study needs n_trials (1 to {limits.max_n_trials})"))
    elif doc.n_trials > limits.max_n_trials:
        problems.append(Problem(("n_trials",), doc.n_trials, f"at most {limits.max_n_trials}"))
    if doc.parallelism > limits.max_parallelism:
        problems.append(Problem(("parallelism",), doc.parallelism, f"at most {limits.max_parallelism}"))
    if doc.kind == "calibrate":
        for key in ("objectives", "constraints"):
            if getattr(doc, key):
                problems.append(Problem((key,), "...", f"a calibrate study minimises its misfit to the measurements; it takes no {key}"))
    elif not doc.objectives:
        problems.append(Problem(("objectives",), [], "give at least one objective: [{metric: thrust_force_N_per_mm, direction: minimize}]"))
    if len(doc.objectives) > limits.max_objectives:
        problems.append(Problem(("objectives",), len(doc.objectives), f"at most {limits.max_objectives} objectives"))
    if len(doc.constraints) > limits.max_constraints:
        problems.append(Problem(("constraints",), len(doc.constraints), f"at most {limits.max_constraints} constraints"))
    if len({o.metric for o in doc.objectives}) != len(doc.objectives):
        problems.append(Problem(("objectives",), [o.metric for o in doc.objectives], "an objective metric appears twice"))
    if doc.sampler == "cmaes":
        if len(doc.objectives) > 1:
            problems.append(Problem(("sampler",), "cmaes", "CMA-ES optimises one objective; allowed for several: tpe, nsga2, gp"))
        if doc.constraints:
            problems.append(Problem(("sampler",), "cmaes", "CMA-ES does not take constraints; allowed with constraints: tpe, nsga2, gp"))
    if doc.sampler == "gp" and not _torch_available():
        problems.append(Problem(("sampler",), "gp", "the GP sampler needs torch, not installed on this server "
                                                  "(pip install 'fibrecut[gp]'); allowed here: tpe, cmaes, nsga2"))
    for name, spec in doc.parameters.items():
        if spec.values is not None and len(spec.values) < 1:
            problems.append(Problem(("parameters", name, "values"), spec.values, "give at least one value"))
    if doc.design != "grid" or doc.n_points is not None:
        problems.append(Problem(("design",), doc.design, f"an {doc.kind} study takes no design/n_points (its sampler chooses the points)"))
    if doc.kind == "optimize" and (doc.measurements or doc.measurements_csv is not None):
        problems.append(Problem(("measurements",), "...", "only a calibrate study takes measurements"))
    if problems:
        raise SceneError(problems)


def _validate_stages(doc: StudyIn, limits: Limits) -> None:
    """confirm (sweep, optimize) and screen (optimize, calibrate): where they apply, one objective
    to rank by, and valid scenes for their runs at both ends of every parameter range."""
    problems = []
    if doc.confirm is not None:
        if doc.kind not in ("sweep", "optimize"):
            problems.append(Problem(("confirm",), "...", "only sweep and optimize studies take confirm"))
        elif len(doc.objectives) != 1:
            problems.append(Problem(("objectives",), [o.metric for o in doc.objectives],
                                    "confirm ranks the trials by one objective; give exactly one objective"))
        if doc.confirm.scene is not None and isinstance(doc.confirm.scene, str) and doc.confirm.scene not in CATALOGUE:
            problems.append(Problem(("confirm", "scene"), doc.confirm.scene, f"unknown built-in scene; allowed: {', '.join(CATALOGUE)} or an inline scene object"))
        for name in doc.confirm.fixed:
            if _field_info(name.split(".")) is None:
                problems.append(Problem(("confirm", "fixed", name), doc.confirm.fixed[name], "unknown scene field (use dotted names such as tool.rake_angle_deg)"))
            elif name in doc.parameters:
                problems.append(Problem(("confirm", "fixed", name), doc.confirm.fixed[name], "is a parameter of the study; the confirmation runs the trials' own values"))
    if doc.screen is not None:
        if doc.kind not in ("optimize", "calibrate"):
            problems.append(Problem(("screen",), "...", "only optimize and calibrate studies take screen"))
        elif doc.screen.top_k > doc.screen.n_trials:
            problems.append(Problem(("screen", "top_k"), doc.screen.top_k, f"at most screen.n_trials ({doc.screen.n_trials})"))
    if problems:
        raise SceneError(problems)
    for stage, spec in (("confirm", doc.confirm), ("screen", doc.screen)):
        if spec is None:
            continue
        scene = stage_scene(doc, stage)
        for name, p in doc.parameters.items():
            checks = [("values", v) for v in p.values] if p.values is not None else [("low", p.low), ("high", p.high)]
            for key, v in checks:
                try:
                    scene_from_dict(scene, {name: v})
                except SceneError as exc:
                    problems.append(Problem((stage,), {name: v}, f"the {stage} runs' scene is invalid at parameters.{name}.{key}: {exc}"))
                    break
    if problems:
        raise SceneError(problems)


def planned_jobs(doc: StudyIn, n_points: int = 0) -> int:
    """Jobs the study will run when every stage runs in full (progress and limits)."""
    per_trial = doc.replicas * (len(doc.measurements) if doc.kind == "calibrate" else 1)
    n = (doc.n_trials or 0) * per_trial if doc.kind in ("optimize", "calibrate") else n_points * doc.replicas
    if doc.screen is not None:
        n += doc.screen.n_trials * (len(doc.measurements) if doc.kind == "calibrate" else 1)
        n += (doc.n_trials or 0) * (len(doc.measurements) if doc.kind == "calibrate" else 1)  # the check runs
    if doc.confirm is not None:
        n += doc.confirm.top_k * doc.confirm.replicas
    return n


def _check_job_budget(doc: StudyIn, limits: Limits, n_points: int) -> None:
    n = planned_jobs(doc, n_points)
    if n > limits.max_jobs_per_study:
        raise SceneError([Problem(("n_trials",), doc.n_trials, f"the study would run {n} jobs (trials x replicas"
                                  f"{' x measurements' if doc.kind == 'calibrate' else ''} and its stages); at most {limits.max_jobs_per_study} jobs per study")])


def _torch_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("torch") is not None


def budget_problems(scene, limits: Limits, loc: tuple[str, ...], overrides: dict | None = None) -> list[Problem]:
    """The scene's size against the limits (solver.budget): its elements, particles, memory and
    wall time. ``loc`` prefixes the field (``fixed``, ``scene``, or a design point's parameters)."""
    from solver.budget import check

    out = [Problem(loc + (f,), v, m) for f, v, m in check(scene, limits.scene)]
    cap = limits.max_job_wall_time_s
    if scene.numerics.max_wall_time_s > cap:
        out.append(Problem(loc + ("numerics.max_wall_time_s",), scene.numerics.max_wall_time_s,
                           f"allowed at most {cap:g} s per job on this server (FIBRECUT_MAX_JOB_WALL_TIME_S)"))
    return out


def create_study(store: Store, doc: StudyIn, limits: Limits) -> int:
    """Validate, then store the study and its jobs (sweep, convergence) or start its trials (optimize, calibrate)."""
    base, points = validate(doc, limits)
    jobs = []
    base_loc = ("scene",) if isinstance(doc.scene, dict) else ("fixed",)
    problems = budget_problems(scene_from_dict(base), limits, base_loc)
    for i, (params, overrides) in enumerate(replicated(points, base, doc.replicas)):
        try:
            scene = scene_from_dict(base, overrides)
        except SceneError as exc:
            raise SceneError([Problem(("parameters",), params, f"design point {i} gives an invalid scene: {exc}")]) from None
        if not problems:
            problems = [Problem(("parameters",) + p.loc[1:], p.value, f"design point {i} ({_point(params)}): {p.message}")
                        for p in budget_problems(scene, limits, ("parameters",))]
        jobs.append((i, params, scene))
    if doc.kind == "optimize":  # the sampler's points are not known yet: every range end and value on its own
        for name, spec in doc.parameters.items():
            for v in (spec.values if spec.values is not None else (spec.low, spec.high)):
                try:
                    scene = scene_from_dict(base, {name: v})
                except SceneError:
                    continue
                problems += [Problem(("parameters", name), v, f"{name} = {v!r}: {p.message}")
                             for p in budget_problems(scene, limits, ("parameters",))]
                if problems:
                    break
    if problems:
        raise SceneError(problems[:5])
    study_id = store.enqueue_study(
        name=doc.name, kind=doc.kind, document=doc.model_dump(mode="json", exclude={"measurements_csv"}),
        planned_jobs=planned_jobs(doc, len(points)) if doc.kind != "convergence" else len(jobs), max_attempts=doc.max_attempts,
        jobs=[NewJob(i, point, scene.model_dump(mode="json"), scene_hash(scene)) for i, point, scene in jobs])
    if doc.kind in ("optimize", "calibrate"):
        store.start_trials(study_id, doc)
        try:
            store.drive(study_id, owner=f"api-{os.getpid()}")  # the first trials at once
        except Exception:  # noqa: BLE001 - the study exists; the server's driver and the workers retry
            log.warning("first drive of study %s failed; it is retried", study_id, exc_info=True)
    return study_id


def replicated(points: list[dict], base: dict, replicas: int) -> list[tuple[dict, dict]]:
    """The jobs of a design as (params, scene overrides). A convergence study's levels run
    ``replicas`` times each: replica k with ``numerics.speed_scaling`` multiplied by
    1 + k REPLICA_PERTURBATION (solver.convergence.replica_speed_scalings), a change no experiment
    could tell, which samples the chaotic spread of the fracture sequence; its params carry
    ``replica`` = k beside the level's own values."""
    if replicas <= 1:
        return [(point, point) for point in points]
    from solver.convergence import replica_speed_scalings

    out = []
    for point in points:
        ss = float(point.get("numerics.speed_scaling", base["numerics"]["speed_scaling"]))
        for k, ssk in enumerate(replica_speed_scalings(ss, replicas)):
            out.append(({**point, "replica": k}, {**point, "numerics.speed_scaling": ssk}))
    return out


def _point(params: dict) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in params.items())
