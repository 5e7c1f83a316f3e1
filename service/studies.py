"""Studies: validation of a study document, its jobs, and the optuna ask-and-tell driver.

- ``sweep``: a grid, Latin hypercube or Sobol design over dotted scene fields; all jobs at once.
- ``convergence``: the same scene at several ``numerics.element_size_um`` and/or mass/speed
  scaling levels (a grid); every level is a job whose metrics and wall time are stored, and the
  trials carry their relative error against the finest level.
- ``optimize``: optuna (TPE by default; CMA-ES, GP, NSGA-II) with its storage in the same
  database (``RDBStorage`` on the service's URL, study ``fibrecut-<id>``). The service asks for
  trials (at most ``parallelism`` in flight), the workers run them as jobs, and the driver tells
  optuna each outcome. Optuna's own heartbeat does not apply to ask-and-tell, so the job
  leases tell the truth: a job requeued after a lost worker keeps its trial running; a job that
  failed, was cancelled or ran out of attempts fails its trial; a trial asked but never turned
  into a job (a crash in between) is failed on the next drive.

One process at a time drives a study: the driver takes a short lease on the study row
(``driver_owner``/``driver_until``) by an atomic UPDATE, so the API, the workers and any
number of servers may all call :func:`drive` safely.
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
import threading
import time
import uuid
from typing import Any

import sqlalchemy as sa

from solver.catalogue import CATALOGUE, scene_dict
from solver.scene import Problem, SceneError, _field_info, scene_from_dict

from . import designs
from .config import Limits
from .db import Database
from .inputs import bool_problems
from .models import TERMINAL_JOB_STATES, Job, Study
from .schemas import StudyIn
from .stages import driven

log = logging.getLogger("fibrecut.studies")
CONVERGENCE_FIELDS = ("numerics.element_size_um", "numerics.mass_scaling", "numerics.speed_scaling")
DRIVER_LEASE_S = float(os.environ.get("FIBRECUT_DRIVER_LEASE_S", "30"))  # a dead driver blocks its study this long


# ------------------------------------------------------------------ validation
def scene_hash(scene) -> str:
    return hashlib.sha256(scene.canonical_json().encode()).hexdigest()


def _base_scene(doc: StudyIn) -> dict:
    if isinstance(doc.scene, str):
        if doc.scene not in CATALOGUE:
            raise SceneError([Problem(("scene",), doc.scene, f"unknown built-in scene; allowed: {', '.join(CATALOGUE)} or an inline scene object")])
        return scene_dict(doc.scene)
    data = dict(doc.scene)
    if "base" in data:
        base = data.pop("base")
        if not isinstance(base, str) or base not in CATALOGUE:
            raise SceneError([Problem(("scene", "base"), base, f"unknown built-in scene; allowed: {', '.join(CATALOGUE)}")])
        merged = scene_dict(base)
        _deep_update(merged, data)
        data = merged
    return data


def _deep_update(dst: dict, src: dict) -> None:
    for k, v in src.items():
        if isinstance(v, dict) and isinstance(dst.get(k), dict):
            _deep_update(dst[k], v)
        else:
            dst[k] = v


def _scene_problems(exc: SceneError, where: tuple[str, ...], overrides: dict) -> list[Problem]:
    out = []
    for p in exc.problems:
        if p.field in overrides:
            out.append(Problem(where + (p.field,), p.value, p.message))
        else:
            out.append(Problem(("scene", p.field), p.value, p.message))
    return out


def build_scene(base: dict, overrides: dict, where: tuple[str, ...] = ("fixed",)):
    try:
        return scene_from_dict(base, overrides)
    except SceneError as exc:
        raise SceneError(_scene_problems(exc, where, overrides)) from None


def _is_int_field(name: str) -> bool:
    info = _field_info(name.split("."))
    return info is not None and info.annotation is int


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
        from . import calibration

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


def stage_scene(doc: StudyIn, stage: str) -> dict:
    """The scene (user units, as a dict) every job of ``stage`` starts from, before the trial's
    parameters: the study's scene with ``fixed``; a screening (and its check runs) at the
    screening fidelity; a confirmation on its own scene and/or fidelity with the study's fixed
    fields (but the fidelity) and its own ``fixed`` on top."""
    if stage in ("screen", "check"):
        return build_scene(_base_scene(doc), {**doc.fixed, "fidelity": doc.screen.fidelity}, ("screen",)).model_dump(mode="json")
    if stage == "confirm":
        c = doc.confirm
        try:
            base = _base_scene(doc) if c.scene is None else _base_scene(StudyIn.model_construct(scene=c.scene))
        except SceneError as exc:
            raise SceneError([Problem(("confirm",) + p.loc, p.value, p.message) for p in exc.problems]) from None
        fixed = dict(doc.fixed)
        if c.scene is not None or c.fidelity is not None:
            fixed.pop("fidelity", None)
        fixed.update(c.fixed)
        if c.fidelity is not None:
            fixed["fidelity"] = c.fidelity
        return build_scene(base, fixed, ("confirm",)).model_dump(mode="json")
    return build_scene(_base_scene(doc), doc.fixed).model_dump(mode="json")


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


# ------------------------------------------------------------------ creation
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


def create_study(db: Database, doc: StudyIn, limits: Limits) -> int:
    """Validate, store the study and its jobs (sweep/convergence) or its optuna study (optimize)."""
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
    t = time.time()
    with db.write() as s:
        st = Study(name=doc.name, kind=doc.kind, status="queued", document=doc.model_dump(mode="json", exclude={"measurements_csv"}),
                   planned_jobs=planned_jobs(doc, len(points)) if doc.kind != "convergence" else len(jobs), created_at=t, updated_at=t)
        s.add(st)
        s.flush()
        study_id = st.id
        s.add_all([Job(study_id=study_id, index=i, params=point, scene=scene.model_dump(mode="json"), scene_hash=scene_hash(scene),
                       status="queued", attempts=0, max_attempts=doc.max_attempts, cancel_requested=False, progress=0.0,
                       cached=False, told=False, created_at=t) for i, point, scene in jobs])
    if doc.kind in ("optimize", "calibrate"):
        _create_optuna_study(db, study_id, doc)
        try:
            drive(db, study_id, owner=f"api-{os.getpid()}")  # the first trials at once
        except Exception:  # noqa: BLE001 - the study exists; the server's driver and the workers retry
            log.warning("first drive of study %s failed; it is retried", study_id, exc_info=True)
    return study_id


def _point(params: dict) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in params.items())


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


# ------------------------------------------------------------------ optuna
_storages: dict[str, Any] = {}
_storage_lock = threading.Lock()


def optuna_storage(db: Database):
    """optuna's RDBStorage on the service's own database (one per process and URL)."""
    import optuna

    with _storage_lock:
        if db.url not in _storages:
            kwargs: dict[str, Any] = {}
            if db.sqlite:
                kwargs["connect_args"] = {"timeout": 60, "check_same_thread": False}
            storage = _new_rdb_storage(optuna, db.url, kwargs)
            if db.sqlite:
                from .db import configure_sqlite_engine

                configure_sqlite_engine(storage.engine, immediate=True)
            _storages[db.url] = storage
        return _storages[db.url]


def _new_rdb_storage(optuna, url: str, kwargs: dict):
    """optuna's RDBStorage, created by the first process to reach a new database: the server and the workers
    may create its tables at the same moment, and the loser of that race gets an IntegrityError from the
    version stamp (``alembic_version``); the tables exist by then, so a second attempt finds them."""
    import sqlalchemy.exc

    for attempt in range(5):
        try:
            return optuna.storages.RDBStorage(url, engine_kwargs=kwargs)
        except (sqlalchemy.exc.IntegrityError, sqlalchemy.exc.OperationalError):
            if attempt == 4:
                raise
            time.sleep(0.2 * (attempt + 1))


def forget_storages() -> None:
    with _storage_lock:
        _storages.clear()


def optuna_name(study_id: int) -> str:
    return f"fibrecut-{study_id}"


def _create_optuna_study(db: Database, study_id: int, doc: StudyIn) -> None:
    """The study's optuna study, with its metric names (the objectives; a calibration's misfit)."""
    from .driver import create_optuna_study

    create_optuna_study(db, study_id, doc, "search")


def distributions(doc: StudyIn, parameters: dict | None = None) -> dict:
    """optuna's distributions of the study's parameters (or of ``parameters``, a refinement box)."""
    from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

    out = {}
    for name, spec in (doc.parameters if parameters is None else parameters).items():
        if spec.values is not None:
            out[name] = CategoricalDistribution(list(spec.values))
        elif _is_int_field(name) and float(spec.low).is_integer() and float(spec.high).is_integer() and (spec.step is None or float(spec.step).is_integer()):
            out[name] = IntDistribution(int(spec.low), int(spec.high), log=spec.log, step=int(spec.step or 1))
        else:
            out[name] = FloatDistribution(spec.low, spec.high, log=spec.log, step=spec.step)
    return out


def constraint_values(doc: StudyIn, metrics: dict) -> list[float] | None:
    """optuna's convention: a value <= 0 is feasible."""
    out = []
    for c in doc.constraints:
        m = metrics.get(c.metric)
        if m is None or not math.isfinite(float(m)):
            return None
        out.append(float(m) - c.value if c.op == "<=" else c.value - float(m))
    return out


def make_sampler(doc: StudyIn, n_existing: int):
    import warnings

    import optuna

    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    # the sampler is rebuilt at every drive; offset the seed so that re-built samplers do not repeat points
    seed = None if doc.seed is None else (doc.seed * 100_003 + n_existing) % (2**31)
    if doc.sampler == "tpe":
        return optuna.samplers.TPESampler(seed=seed, constant_liar=True,
                                          n_startup_trials=min(10, max(2, (doc.n_trials or 10) // 4)),
                                          multivariate=True)
    if doc.sampler == "cmaes":
        return optuna.samplers.CmaEsSampler(seed=seed, n_startup_trials=min(10, max(1, (doc.n_trials or 10) // 5)))
    if doc.sampler == "gp":
        return optuna.samplers.GPSampler(seed=seed)
    if doc.sampler == "nsga2":
        pop = max(4, min(50, (doc.n_trials or 40) // 4))
        return optuna.samplers.NSGAIISampler(seed=seed, population_size=pop)
    raise ValueError(doc.sampler)


def _take_driver_lease(db: Database, study_id: int, owner: str) -> bool:
    t = time.time()
    with db.write() as s:
        n = s.execute(sa.update(Study).where(
            Study.id == study_id,
            (Study.driver_until.is_(None)) | (Study.driver_until < t) | (Study.driver_owner == owner),
        ).values(driver_owner=owner, driver_until=t + DRIVER_LEASE_S)).rowcount
    return n == 1


def _release_driver_lease(db: Database, study_id: int, owner: str) -> None:
    with db.write() as s:
        s.execute(sa.update(Study).where(Study.id == study_id, Study.driver_owner == owner).values(driver_owner=None, driver_until=None))


def drive(db: Database, study_id: int, owner: str | None = None) -> None:
    """Tell optuna what finished, ask for new trials up to ``parallelism`` in flight and
    ``n_trials`` in all, and end the study when every trial is told. Idempotent and resumable."""
    owner = owner or f"{os.uname().nodename}-{os.getpid()}-{threading.get_ident()}"
    with db.read() as s:
        st = s.get(Study, study_id)
        if st is None or not driven(st.kind, st.document) or st.status in ("done", "failed"):
            return
    if not _take_driver_lease(db, study_id, owner):
        return
    try:
        _drive(db, study_id)
    finally:
        _release_driver_lease(db, study_id, owner)


def _drive(db: Database, study_id: int) -> None:
    from .driver import drive_study

    drive_study(db, study_id)


def active_driven_studies(db: Database) -> list[int]:
    """Studies a driver moves forward (optimisations, calibrations, sweeps with a confirmation)
    that are not finished, and cancelled ones with trials still to tell optuna."""
    untold = sa.select(Job.id).where(Job.study_id == Study.id, Job.trial_number.is_not(None), ~Job.told,
                                     Job.status.in_(TERMINAL_JOB_STATES)).exists()
    with db.read() as s:
        rows = s.execute(sa.select(Study.id, Study.kind, Study.status).where(
            Study.kind.in_(("optimize", "calibrate", "sweep")),
            Study.status.in_(("queued", "running")) | ((Study.status == "cancelled") & untold))).all()
        sweeps = [r.id for r in rows if r.kind == "sweep"]
        docs = dict(s.execute(sa.select(Study.id, Study.document).where(Study.id.in_(sweeps))).all()) if sweeps else {}
    return [r.id for r in rows if driven(r.kind, docs.get(r.id))]



def drive_all(db: Database, owner: str | None = None) -> None:
    """One pass of the scheduler: drive every optimisation, calibration and staged sweep that is not finished."""
    for sid in active_driven_studies(db):
        drive(db, sid, owner)


def new_run_id() -> str:
    return uuid.uuid4().hex
