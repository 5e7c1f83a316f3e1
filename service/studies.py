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
from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa

from solver.catalogue import CATALOGUE, scene_dict
from solver.budget import check as budget_check
from solver.scene import Problem as SceneProblem
from solver.scene import SceneError, _field_info, scene_from_dict

from . import designs
from .config import Limits
from .db import Database
from .inputs import bool_problems
from .models import TERMINAL_JOB_STATES, Job, Run, Study
from .schemas import StudyIn

log = logging.getLogger("fibrecut.studies")
CONVERGENCE_FIELDS = ("numerics.element_size_um", "numerics.mass_scaling", "numerics.speed_scaling")
DRIVER_LEASE_S = float(os.environ.get("FIBRECUT_DRIVER_LEASE_S", "30"))  # a dead driver blocks its study this long


# ------------------------------------------------------------------ errors
@dataclass
class Problem:
    loc: tuple[str, ...]  # path inside the study document; dotted scene fields stay one element
    value: Any
    message: str

    @property
    def field(self) -> str:
        return ".".join(self.loc)

    def __str__(self) -> str:
        return f"{self.field} = {self.value!r}: {self.message}"


class StudyError(ValueError):
    """Invalid study document; each problem names its field, the value and what is allowed."""

    def __init__(self, problems: list[Problem]):
        self.problems = problems
        super().__init__("; ".join(str(p) for p in problems))


# ------------------------------------------------------------------ validation
def scene_hash(scene) -> str:
    return hashlib.sha256(scene.canonical_json().encode()).hexdigest()


def _base_scene(doc: StudyIn) -> dict:
    if isinstance(doc.scene, str):
        if doc.scene not in CATALOGUE:
            raise StudyError([Problem(("scene",), doc.scene, f"unknown built-in scene; allowed: {', '.join(CATALOGUE)} or an inline scene object")])
        return scene_dict(doc.scene)
    data = dict(doc.scene)
    if "base" in data:
        base = data.pop("base")
        if not isinstance(base, str) or base not in CATALOGUE:
            raise StudyError([Problem(("scene", "base"), base, f"unknown built-in scene; allowed: {', '.join(CATALOGUE)}")])
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
        raise StudyError(_scene_problems(exc, where, overrides)) from None


def _is_int_field(name: str) -> bool:
    info = _field_info(name.split("."))
    return info is not None and info.annotation is int


def validate(doc: StudyIn, limits: Limits) -> tuple[dict, list[dict[str, Any]]]:
    """Check a study document against the scene schema and the limits.

    Returns the base scene dict (with ``fixed`` applied) and, for sweeps and convergence
    studies, the list of design points. Raises :class:`StudyError`.
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
        raise StudyError(problems)
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
        raise StudyError(problems)

    if doc.kind == "optimize":
        _validate_optimize(doc, limits)
        return base_fixed, []
    for key in ("objectives", "constraints"):
        if getattr(doc, key):
            problems.append(Problem((key,), "...", f"only an optimize study takes {key}"))
    if doc.replicas > 1 and doc.kind != "convergence":
        problems.append(Problem(("replicas",), doc.replicas, "only a convergence study takes replicas (use 1)"))
    design = "grid" if doc.kind == "convergence" else doc.design
    if design == "grid":
        for name, spec in doc.parameters.items():
            if spec.values is None and spec.step is None:
                problems.append(Problem(("parameters", name), {"low": spec.low, "high": spec.high},
                                        "a grid over a range needs step (or give values: [...]); or use design lhs or sobol"))
        if problems:
            raise StudyError(problems)
        size = designs.grid_size(doc.parameters) * doc.replicas
        if size > limits.max_jobs_per_study:
            what = f"the grid has {size / doc.replicas:.4g} points x {doc.replicas} replicas" if doc.replicas > 1 else f"the grid has {size:.4g} points"
            raise StudyError([Problem(("parameters",), size, f"{what}; at most {limits.max_jobs_per_study} jobs per study")])
        points = designs.grid(doc.parameters)
    else:
        if doc.n_points is None:
            raise StudyError([Problem(("n_points",), None, f"design {design} needs n_points (1 to {limits.max_jobs_per_study})")])
        if doc.n_points > limits.max_jobs_per_study:
            raise StudyError([Problem(("n_points",), doc.n_points, f"at most {limits.max_jobs_per_study} jobs per study")])
        points = designs.sample(doc.parameters, design, doc.n_points, doc.seed)
    return base_fixed, points


def _validate_optimize(doc: StudyIn, limits: Limits) -> None:
    problems = []
    if doc.n_trials is None:
        problems.append(Problem(("n_trials",), None, f"an optimize study needs n_trials (1 to {limits.max_n_trials})"))
    elif doc.n_trials > limits.max_n_trials:
        problems.append(Problem(("n_trials",), doc.n_trials, f"at most {limits.max_n_trials}"))
    if doc.parallelism > limits.max_parallelism:
        problems.append(Problem(("parallelism",), doc.parallelism, f"at most {limits.max_parallelism}"))
    if not doc.objectives:
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
        problems.append(Problem(("design",), doc.design, "an optimize study takes no design/n_points (its sampler chooses the points)"))
    if problems:
        raise StudyError(problems)


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
            raise StudyError([Problem(("parameters",), params, f"design point {i} gives an invalid scene: {exc}")]) from None
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
        raise StudyError(problems[:5])
    t = time.time()
    with db.write() as s:
        st = Study(name=doc.name, kind=doc.kind, status="queued", document=doc.model_dump(mode="json"),
                   planned_jobs=len(jobs) if doc.kind != "optimize" else int(doc.n_trials), created_at=t, updated_at=t)
        s.add(st)
        s.flush()
        study_id = st.id
        s.add_all([Job(study_id=study_id, index=i, params=point, scene=scene.model_dump(mode="json"), scene_hash=scene_hash(scene),
                       status="queued", attempts=0, max_attempts=doc.max_attempts, cancel_requested=False, progress=0.0,
                       cached=False, told=False, created_at=t) for i, point, scene in jobs])
    if doc.kind == "optimize":
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
            storage = optuna.storages.RDBStorage(db.url, engine_kwargs=kwargs)
            if db.sqlite:
                from .db import configure_sqlite_engine

                configure_sqlite_engine(storage.engine, immediate=True)
            _storages[db.url] = storage
        return _storages[db.url]


def forget_storages() -> None:
    with _storage_lock:
        _storages.clear()


def optuna_name(study_id: int) -> str:
    return f"fibrecut-{study_id}"


def _create_optuna_study(db: Database, study_id: int, doc: StudyIn) -> None:
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    directions = [o.direction for o in doc.objectives]
    optuna.create_study(storage=optuna_storage(db), study_name=optuna_name(study_id), directions=directions, load_if_exists=True)


def distributions(doc: StudyIn) -> dict:
    from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

    out = {}
    for name, spec in doc.parameters.items():
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
        if st is None or st.kind != "optimize" or st.status in ("done", "failed"):
            return
    if not _take_driver_lease(db, study_id, owner):
        return
    try:
        _drive(db, study_id)
    finally:
        _release_driver_lease(db, study_id, owner)


def _drive(db: Database, study_id: int) -> None:
    import optuna
    from optuna.trial import TrialState

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    with db.read() as s:
        st = s.get(Study, study_id)
        doc = StudyIn.model_validate(st.document)
        status = st.status
        jobs = s.execute(sa.select(Job.id, Job.trial_number, Job.status, Job.told, Job.run_id, Job.error)
                         .where(Job.study_id == study_id).order_by(Job.index)).all()
        runs = {r.id: r for r in s.execute(sa.select(Run.id, Run.status, Run.summary)
                                           .where(Run.id.in_([j.run_id for j in jobs if j.run_id]))).all()}
    storage = optuna_storage(db)
    study = optuna.load_study(study_name=optuna_name(study_id), storage=storage, sampler=make_sampler(doc, len(jobs)))
    trials = {t.number: t for t in study.get_trials(deepcopy=False)}

    # 1. tell optuna the truth about every finished job
    told_ids = []
    for j in jobs:
        if j.status not in TERMINAL_JOB_STATES or j.told or j.trial_number is None:
            continue
        ft = trials.get(j.trial_number)
        if ft is not None and ft.state == TrialState.RUNNING:
            trial_id = ft._trial_id
            run = runs.get(j.run_id)
            metrics = (run.summary if run else None) or {}
            values = [metrics.get(o.metric) for o in doc.objectives]
            storage.set_trial_user_attr(trial_id, "job_id", j.id)
            storage.set_trial_user_attr(trial_id, "run_id", j.run_id)
            ok = j.status == "done" and all(v is not None and math.isfinite(float(v)) for v in values)
            cv = constraint_values(doc, metrics) if doc.constraints else []
            if ok and cv is not None:
                trial = optuna.trial.Trial(study, trial_id)
                for i, (c, v) in enumerate(zip(doc.constraints, cv)):
                    trial.set_constraint(f"c{i}_{c.metric}", v)  # optuna: <= 0 is feasible
                study.tell(j.trial_number, [float(v) for v in values])
            else:
                reason = j.error or (f"job {j.status}" if j.status != "done" else "an objective or constraint metric is missing")
                storage.set_trial_user_attr(trial_id, "fail_reason", str(reason)[:1000])
                study.tell(j.trial_number, state=TrialState.FAIL)
        told_ids.append(j.id)
    if told_ids:
        with db.write() as s:
            s.execute(sa.update(Job).where(Job.id.in_(told_ids)).values(told=True))

    # 2. trials asked but never turned into a job (a crash between ask and insert): fail them
    with_job = {j.trial_number for j in jobs if j.trial_number is not None}
    for number, ft in trials.items():
        if ft.state == TrialState.RUNNING and number not in with_job:
            study.tell(number, state=TrialState.FAIL)

    n_jobs = len(jobs)
    in_flight = sum(1 for j in jobs if j.status not in TERMINAL_JOB_STATES)
    if status == "cancelled":
        return

    # 3. ask for new trials
    base = _base_scene(doc)
    base_fixed = scene_from_dict(base, doc.fixed).model_dump(mode="json")
    dists = distributions(doc)
    while n_jobs < doc.n_trials and in_flight < doc.parallelism:
        trial = study.ask(dists)
        params = dict(trial.params)
        t = time.time()
        try:
            scene = scene_from_dict(base_fixed, params)
            too_large = budget_check(scene)
            if too_large:
                raise SceneError([SceneProblem(f, v, m) for f, v, m in too_large])
        except SceneError as exc:
            # an invalid combination: recorded as a failed trial, told at once
            storage.set_trial_user_attr(trial._trial_id, "fail_reason", str(exc)[:1000])
            study.tell(trial.number, state=TrialState.FAIL)
            with db.write() as s:
                s.add(Job(study_id=study_id, index=n_jobs, trial_number=trial.number, params=params,
                          scene=base_fixed, scene_hash="-", status="failed", attempts=0, max_attempts=doc.max_attempts,
                          cancel_requested=False, progress=0.0, cached=False, told=True, created_at=t, finished_at=t,
                          error=f"invalid scene: {exc}"))
            n_jobs += 1
            continue
        with db.write() as s:
            s.add(Job(study_id=study_id, index=n_jobs, trial_number=trial.number, params=params,
                      scene=scene.model_dump(mode="json"), scene_hash=scene_hash(scene), status="queued", attempts=0,
                      max_attempts=doc.max_attempts, cancel_requested=False, progress=0.0, cached=False, told=False, created_at=t))
        n_jobs += 1
        in_flight += 1

    # 4. the end: every trial asked and told
    if n_jobs >= doc.n_trials and in_flight == 0:
        with db.write() as s:
            open_jobs = s.execute(sa.select(sa.func.count()).select_from(Job).where(
                Job.study_id == study_id, (Job.status.not_in(TERMINAL_JOB_STATES)) | (~Job.told))).scalar()
            n_done = s.execute(sa.select(sa.func.count()).select_from(Job).where(Job.study_id == study_id, Job.status == "done")).scalar()
            st = s.get(Study, study_id)
            if open_jobs == 0 and st.status not in ("cancelled", "done", "failed"):
                t = time.time()
                st.status = "done" if n_done else "failed"
                st.error = None if n_done else "no trial finished successfully"
                st.finished_at = t
                st.updated_at = t


def active_optimize_studies(db: Database) -> list[int]:
    untold = sa.select(Job.id).where(Job.study_id == Study.id, Job.trial_number.is_not(None), ~Job.told,
                                     Job.status.in_(TERMINAL_JOB_STATES)).exists()
    with db.read() as s:
        return [r[0] for r in s.execute(sa.select(Study.id).where(
            Study.kind == "optimize", Study.status.in_(("queued", "running")) | ((Study.status == "cancelled") & untold))).all()]


def drive_all(db: Database, owner: str | None = None) -> None:
    """One pass of the scheduler: drive every optimisation that is not finished."""
    for sid in active_optimize_studies(db):
        drive(db, sid, owner)


def new_run_id() -> str:
    return uuid.uuid4().hex
