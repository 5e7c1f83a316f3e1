"""/api/studies: create, list, show, trials (JSON and CSV, paged), points (one per trial: means over
its replicas), a calibration's scene preset, cancel; /api/measurements: check a measurement CSV."""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Path, Query, Request, Response, status

from solver.scene import Problem, SceneError
from store import Store
from store.documents import StudyIn
from store.models import Study

from .. import report, studies
from ..config import Settings
from ..deps import get_db, get_settings, require_token
from ..schemas import MeasurementsOut, PointsPage, StudyOut, TrialOut

router = APIRouter(prefix="/api/studies", tags=["studies"])

_404 = {404: {"description": "no such study"}}
MAX_ID = 2**31 - 1  # the id columns' range on PostgreSQL (integer); SQLite's is wider
StudyId = Path(..., ge=1, le=MAX_ID, description="the study's id")


def _study(s, study_id: int) -> Study:
    st = s.get(Study, study_id)
    if st is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"study {study_id} not found")
    return st


@router.post("", response_model=StudyOut, status_code=201, dependencies=[Depends(require_token)],
             responses={400: {"description": "invalid Content-Length"}, 401: {"description": "token required"},
                        413: {"description": "body too large"}})
def create_study(doc: StudyIn, db: Store = Depends(get_db), settings: Settings = Depends(get_settings)):
    """Submit a study document (sweep, optimize or convergence); invalid input answers 422 naming the field."""
    study_id = studies.create_study(db, doc, settings.limits)
    with db.read() as s:
        return report.study_out(s, _study(s, study_id))


@router.get("", response_model=list[StudyOut])
def list_studies(limit: int = Query(100, ge=1, le=1000), offset: int = Query(0, ge=0, le=10**9),
                 status_: str | None = Query(None, alias="status", pattern="^(queued|running|done|failed|cancelled)$"),
                 db: Store = Depends(get_db)):
    import sqlalchemy as sa

    with db.read() as s:
        q = sa.select(Study).order_by(Study.id.desc()).limit(limit).offset(offset)
        if status_:
            q = q.where(Study.status == status_)
        return [report.study_out(s, st, with_document=False) for st in s.execute(q).scalars()]


@router.get("/{study_id}", response_model=StudyOut, responses=_404)
def get_study(study_id: int = StudyId, db: Store = Depends(get_db)):
    with db.read() as s:
        return report.study_out(s, _study(s, study_id))


@router.get("/{study_id}/trials", response_model=list[TrialOut], responses=_404)
def get_trials(study_id: int = StudyId,
               limit: int | None = Query(None, ge=1, le=100000, description="at most this many trials (paging)"),
               offset: int = Query(0, ge=0, le=10**9), db: Store = Depends(get_db)):
    """The study's jobs in order (with replicas: one per replica, each with its trial's aggregate)."""
    with db.read() as s:
        rows = report.trials(s, _study(s, study_id))
    return rows[offset:] if limit is None else rows[offset:offset + limit]


@router.get("/{study_id}/points", response_model=PointsPage, responses=_404)
def get_points(study_id: int = StudyId, stage: str | None = Query(None, pattern="^(search|screen|check|confirm)$"),
               limit: int = Query(100, ge=1, le=10000), offset: int = Query(0, ge=0, le=10**9), db: Store = Depends(get_db)):
    """One entry per trial and stage: parameters, replicas (ok ones), per metric mean, sd, sem and n,
    rank, best and statistically tied marks. Sweeps without replicas or objectives and convergence
    studies have no points (their trials are their jobs)."""
    with db.read() as s:
        return report.points_page(s, _study(s, study_id), stage, limit, offset)


@router.get("/{study_id}/points.csv", response_class=Response, responses={200: {"content": {"text/csv": {}}}, **_404})
def get_points_csv(study_id: int = StudyId, db: Store = Depends(get_db)):
    """The points as CSV: one row per trial and stage, per metric mean, sd, sem and n."""
    with db.read() as s:
        pts, _ = report.study_points(s, _study(s, study_id))
    return Response(report.points_csv(pts), media_type="text/csv",
                    headers={"Content-Disposition": f'attachment; filename="study-{study_id}-points.csv"'})


@router.get("/{study_id}/calibrated-scene.yaml", response_class=Response, responses={200: {"content": {"application/yaml": {}}}, 409: {"description": "no fitted values yet"}, **_404})
def get_calibrated_scene(study_id: int = StudyId, db: Store = Depends(get_db)):
    """The calibration's scene preset as a scene file for `fibrecut run FILE.yaml`."""
    import yaml

    with db.read() as s:
        st = _study(s, study_id)
        if st.kind != "calibrate":
            raise HTTPException(status.HTTP_409_CONFLICT, detail=f"study {study_id} is a {st.kind} study, not a calibration")
        _, conclusions = report.study_points(s, st)
    cal = conclusions.get("calibration")
    if not cal:
        raise HTTPException(status.HTTP_409_CONFLICT, detail=f"study {study_id} has no finished calibration trial yet")
    text = (f"# calibrated by study {study_id} ({st.name}): misfit {cal['misfit']:.4g} standard deviations over "
            f"{cal['n_values']} measured values\n") + yaml.safe_dump(cal["preset"], sort_keys=False)
    return Response(text, media_type="application/yaml",
                    headers={"Content-Disposition": f'attachment; filename="study-{study_id}-calibrated-scene.yaml"'})


@router.get("/{study_id}/trials.csv", response_class=Response, responses={200: {"content": {"text/csv": {}}}, **_404})
def get_trials_csv(study_id: int = StudyId, db: Store = Depends(get_db)):
    with db.read() as s:
        text = report.trials_csv(report.trials(s, _study(s, study_id)))
    return Response(text, media_type="text/csv",
                    headers={"Content-Disposition": f'attachment; filename="study-{study_id}-trials.csv"'})


@router.post("/{study_id}/cancel", response_model=StudyOut, dependencies=[Depends(require_token)],
             responses={**_404, 400: {"description": "invalid Content-Length"}, 401: {"description": "token required"},
                        413: {"description": "body too large"}})
def cancel_study(study_id: int = StudyId, db: Store = Depends(get_db)):
    """Cancel queued jobs at once; running jobs stop at their worker's next heartbeat."""
    if not db.cancel(study_id):
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"study {study_id} not found")
    with db.read() as s:
        return report.study_out(s, _study(s, study_id))


measurements_router = APIRouter(prefix="/api/measurements", tags=["studies"])


@measurements_router.post("", response_model=MeasurementsOut, responses={422: {"description": "a problem, naming its row and column"}},
                          openapi_extra={"requestBody": {"content": {"text/csv": {"schema": {"type": "string"}}}, "required": True}})
async def parse_measurements(request: Request):
    """Check a calibration's measurement CSV (the body, text/csv) and answer its points as the
    study document's ``measurements``; a problem answers 422 naming the row and the column."""
    from store import calibration

    raw = await request.body()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError([Problem(("measurements_csv",), f"byte {exc.start}", "not UTF-8 text")]) from None
    return {"measurements": calibration.parse_csv(text)}
