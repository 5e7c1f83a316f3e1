"""/api/runs: a run's summary, its HDF5 file, its time series and its frames."""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Path as PathParam, Query, status
from fastapi.responses import FileResponse

from store import Store

from .. import discretisation, results
from ..config import Settings
from ..deps import get_db, get_settings
from ..schemas import RunOut

router = APIRouter(prefix="/api/runs", tags=["runs"])

RunId = PathParam(..., min_length=32, max_length=32, pattern="^[0-9a-f]{32}$", description="uuid4 hex")
_404 = {404: {"description": "no such run, or no file for it"}}


def _run(db: Store, run_id: str):
    run = db.run(run_id)
    if run is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"run {run_id} not found")
    return run


def _file(db: Store, settings: Settings, run_id: str):
    run = _run(db, run_id)
    path = results.run_path(settings.runs_dir, run.id)  # built from the database's id, not the request
    if not run.has_file or not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"run {run_id} has no result file")
    return path


@router.get("/{run_id}", response_model=RunOut, responses=_404)
def get_run(run_id: str = RunId, db: Store = Depends(get_db)):
    r = _run(db, run_id)
    with db.read() as s:
        estimate = discretisation.estimate(s, r)
    return RunOut(id=r.id, job_id=r.job_id, status=r.status, summary=r.summary, diagnosis=r.diagnosis, wall_time_s=r.wall_time_s,
                  solver_version=r.solver_version, host=r.host, worker_id=r.worker_id, created_at=r.created_at, has_file=r.has_file,
                  estimated_discretisation_error=estimate)


@router.get("/{run_id}/result.h5", response_class=FileResponse, responses={200: {"content": {"application/x-hdf5": {}}}, **_404})
def get_result_file(run_id: str = RunId, db: Store = Depends(get_db), settings: Settings = Depends(get_settings)):
    path = _file(db, settings, run_id)
    return FileResponse(path, media_type="application/x-hdf5", filename=f"run-{run_id}.h5")


@router.get("/{run_id}/series", responses=_404)
def get_series(run_id: str = RunId, max_points: int = Query(1000, ge=2, le=20000),
               db: Store = Depends(get_db), settings: Settings = Depends(get_settings)):
    """The run's HDF5 groups forces, energies and diagnostics as JSON, downsampled to max_points."""
    return results.series(_file(db, settings, run_id), max_points)


@router.get("/{run_id}/frames", responses=_404)
def get_frames(run_id: str = RunId, db: Store = Depends(get_db), settings: Settings = Depends(get_settings)):
    """How many frames the run stored, their times and fields."""
    return results.frame_index(_file(db, settings, run_id))


@router.get("/{run_id}/frames/{k}", responses=_404)
def get_frame(run_id: str = RunId, k: int = PathParam(..., ge=0, le=9999), db: Store = Depends(get_db),
              settings: Settings = Depends(get_settings)):
    """One frame's arrays (positions, material, state, damage, stress: what the scene stored)."""
    fr = results.frame(_file(db, settings, run_id), k)
    if fr is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"run {run_id} has no frame {k}")
    return fr
