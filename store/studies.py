"""Studies in the store: what the workers, the API and the server's driver share about a study
document (its base scene per stage, the canonical scene hash) and the optuna ask-and-tell driver.

- ``optimize`` and ``calibrate``: optuna (TPE by default; CMA-ES, GP, NSGA-II) with its storage in
  the same database (``RDBStorage`` on the store's URL, study ``fibrecut-<id>``). The driver asks
  for trials (at most ``parallelism`` in flight), the workers run them as jobs, and the driver
  tells optuna each outcome. Optuna's own heartbeat does not apply to ask-and-tell, so the job
  leases tell the truth: a job requeued after a lost worker keeps its trial running; a job that
  failed, was cancelled or ran out of attempts fails its trial; a trial asked but never turned
  into a job (a crash in between) is failed on the next drive.
- a sweep with a confirmation stage: the driver starts the confirmation runs after the sweep.

One process at a time drives a study: the driver takes a short lease on the study row
(``driver_owner``/``driver_until``) by an atomic UPDATE, so the API, the workers and any
number of servers may all call :func:`drive` safely.
"""

from __future__ import annotations

import hashlib
import math
import os
import threading
import time
from typing import Any

import sqlalchemy as sa

from solver.catalogue import CATALOGUE, scene_dict
from solver.scene import Problem, SceneError, _deep_update, _field_info, scene_from_dict

from .db import Database
from .documents import StudyIn
from .models import TERMINAL_JOB_STATES, Study, Job
from .stages import driven

DRIVER_LEASE_S = float(os.environ.get("FIBRECUT_DRIVER_LEASE_S", "30"))  # a dead driver blocks its study this long


# ------------------------------------------------------------------ the study's scenes
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


# ------------------------------------------------------------------ optuna
_storages: dict[str, Any] = {}
_storage_lock = threading.Lock()


def optuna_storage(db: Database):
    """optuna's RDBStorage on the store's own database (one per process and URL)."""
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
