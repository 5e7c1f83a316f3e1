"""Read-only endpoints the dashboard needs beyond the REST contract.

- ``GET /api/runs/{id}/context``: the study, job and parameters that produced a run and the
  full validated scene (user units) it ran, so the run page can show the scene and link back.
- ``GET /api/runs/{id}/mesh``: the run's mesh connectivity from the HDF5 group ``/mesh``
  (quads, element material, reference node coordinates in m, initial tool), so chip frames
  (node positions plus per-element material/state/damage/stress) can be drawn as elements.

Included by :func:`service.app.create_app`. No business logic: reads only.
File paths come from the run id stored in the database, never from the request.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, HTTPException, status

from store import Store
from store.models import Job, Run, Study

from .. import results
from ..config import Settings
from ..deps import get_db, get_settings
from .runs import RunId, _run

router = APIRouter(prefix="/api/runs", tags=["dashboard"])

_404 = {404: {"description": "no such run, or no mesh in its file"}}


@router.get("/{run_id}/context", responses=_404)
def run_context(run_id: str = RunId, db: Store = Depends(get_db)) -> dict[str, Any]:
    """Study, job, parameters and scene of a run (the job that computed it; cached jobs share it)."""
    import sqlalchemy as sa

    with db.read() as s:
        run = s.get(Run, run_id)
        if run is None:
            raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"run {run_id} not found")
        job = s.get(Job, run.job_id) if run.job_id is not None else None
        if job is None:  # fall back on any job that points at the run (e.g. a cached one)
            job = s.execute(sa.select(Job).where(Job.run_id == run_id).order_by(Job.id).limit(1)).scalar_one_or_none()
        study = s.get(Study, job.study_id) if job is not None else None
        return {
            "run_id": run_id,
            "job_id": job.id if job else None,
            "study_id": study.id if study else None,
            "study_name": study.name if study else None,
            "trial_index": job.index if job else None,
            "trial_number": job.trial_number if job else None,
            "params": job.params if job else {},
            "scene": job.scene if job else None,
        }


@router.get("/{run_id}/mesh", responses=_404)
def run_mesh(run_id: str = RunId, db: Store = Depends(get_db), settings: Settings = Depends(get_settings)) -> dict[str, Any]:
    """The ``/mesh`` group of the run's file: quads (node indices), element material, reference x, y [m]; for a
    3D run the quads are the faces of its side view and ``elements`` names the element of each."""
    import h5py
    import numpy as np

    run = _run(db, run_id)
    path = results.run_path(settings.runs_dir, run.id)
    if not run.has_file or not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"run {run_id} has no result file")
    with h5py.File(path, "r") as f:
        if "mesh" not in f:
            raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"run {run_id} stored no mesh (it wrote no frames)")
        g = f["mesh"]
        out: dict[str, Any] = {}
        for name in ("quads", "material", "x", "y", "tool0"):
            if name in g:
                out[name] = results._jsonable(np.asarray(g[name][()]))
        if "hexes" in g:  # a 3D strip: its side view, the faces through the first fibres' axes, each with its element
            from solver.fem3d.strip3d import side_section

            X = np.stack([g[c][()] for c in "xyz"])
            quads, elems, zc = side_section(X, g["hexes"][()], float(g["fibre_pitch"][()]))
            out["quads"] = results._jsonable(quads)
            out["elements"] = results._jsonable(elems)
            out["section"] = f"side view: the section z = {zc * 1e6:.4g} um through the first fibres' axes"
        return out
