"""/api/health and /api/scenes (the catalogue the dashboard offers)."""

from __future__ import annotations

import time

import sqlalchemy as sa
from fastapi import APIRouter, Depends

from ..db import Database
from ..deps import get_db
from ..models import Job, Worker
from ..schemas import Health, SceneOut

router = APIRouter(prefix="/api", tags=["service"])


@router.get("/health", response_model=Health)
def health(db: Database = Depends(get_db)):
    from solver.result import SOLVER_VERSION

    with db.read() as s:
        s.execute(sa.text("SELECT 1"))
        queued = s.execute(sa.select(sa.func.count()).select_from(Job).where(Job.status == "queued")).scalar()
        running = s.execute(sa.select(sa.func.count()).select_from(Job).where(Job.status == "running")).scalar()
        seen = s.execute(sa.select(sa.func.count()).select_from(Worker).where(Worker.last_seen > time.time() - 120,
                                                                              Worker.status != "stopped")).scalar()
    return Health(status="ok", database=db.engine.dialect.name, solver_version=SOLVER_VERSION, workers_seen=seen,
                  jobs_queued=queued, jobs_running=running)


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
