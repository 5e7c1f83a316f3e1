"""/api/health and /api/scenes (the catalogue the dashboard offers)."""

from __future__ import annotations

import time

import sqlalchemy as sa
from fastapi import APIRouter, Depends, Query

from store import Store
from store.models import Worker
from store.queue import worker_state

from ..deps import get_db
from ..schemas import Health, SceneOut, WorkerOut

router = APIRouter(prefix="/api", tags=["service"])


@router.get("/health", response_model=Health)
def health(db: Store = Depends(get_db)):
    from solver.result import SOLVER_VERSION

    jobs = db.queue_counts()
    with db.read() as s:
        seen = s.execute(sa.select(sa.func.count()).select_from(Worker).where(Worker.last_seen > time.time() - 120,
                                                                              Worker.status.not_in(("stopped", "lost")))).scalar()
        t = time.time()
        recent = s.execute(sa.select(Worker).where(Worker.last_seen > t - 3600, Worker.status != "stopped")).scalars().all()
        lost = sum(1 for w in recent if worker_state(w, t, _HOST) == "lost")
    return Health(status="ok", database=db.engine.dialect.name, solver_version=SOLVER_VERSION, workers_seen=seen,
                  jobs_queued=jobs["queued"], jobs_running=jobs["running"], workers_lost=lost, kernels=_kernels())


_kernel_state: list = [0.0, "cold"]


def _kernels() -> str:
    """solver.warmup.state(), at most once every 2 s (it hashes the solver's sources)."""
    from solver import warmup

    t = time.time()
    if t - _kernel_state[0] > 2.0:
        _kernel_state[:] = [t, warmup.state()]
    return _kernel_state[1]


_HOST = __import__("socket").gethostname()[:200]


@router.get("/workers", response_model=list[WorkerOut])
def workers(include_stopped: bool = Query(False, description="also workers that stopped or were lost over an hour ago"),
            db: Store = Depends(get_db)):
    """The workers: ``idle``, ``busy``, ``stopped``, or ``lost`` (heartbeat expired, or its process
    on the server's host is gone)."""
    t = time.time()
    host = _HOST
    out = []
    for w in db.workers(limit=1000):
        state = worker_state(w, t, host)
        if state in ("stopped", "lost") and not include_stopped and w.last_seen < t - 3600:
            continue
        out.append(WorkerOut(id=w.id, host=w.host, pid=w.pid, status=state, started_at=w.started_at, last_seen=w.last_seen,
                             jobs_done=w.jobs_done, current_job_id=w.current_job_id if state == "busy" else None))
    return out


_scenes_cache: list[SceneOut] | None = None


@router.get("/scenes", response_model=list[SceneOut])
def scenes():
    """The built-in scenes: name, description, fidelity and the full scene (user units)."""
    global _scenes_cache
    if _scenes_cache is None:
        from solver.catalogue import CATALOGUE
        from solver.scene import load_scene

        out = []
        for name, (_, desc) in CATALOGUE.items():
            sc = load_scene(name)
            out.append(SceneOut(name=name, description=desc, fidelity=sc.fidelity, scene=sc.model_dump(mode="json")))
        _scenes_cache = out
    return _scenes_cache
