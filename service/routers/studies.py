"""/api/studies: create, list, show, trials (JSON and CSV), cancel."""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Path, Query, Response, status

from .. import queue, report, studies
from ..config import Settings
from ..db import Database
from ..deps import get_db, get_settings, require_token
from ..models import Study
from ..schemas import StudyIn, StudyOut, TrialOut

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
def create_study(doc: StudyIn, db: Database = Depends(get_db), settings: Settings = Depends(get_settings)):
    """Submit a study document (sweep, optimize or convergence); invalid input answers 422 naming the field."""
    study_id = studies.create_study(db, doc, settings.limits)
    with db.read() as s:
        return report.study_out(s, _study(s, study_id))


@router.get("", response_model=list[StudyOut])
def list_studies(limit: int = Query(100, ge=1, le=1000), offset: int = Query(0, ge=0, le=10**9),
                 status_: str | None = Query(None, alias="status", pattern="^(queued|running|done|failed|cancelled)$"),
                 db: Database = Depends(get_db)):
    import sqlalchemy as sa

    with db.read() as s:
        q = sa.select(Study).order_by(Study.id.desc()).limit(limit).offset(offset)
        if status_:
            q = q.where(Study.status == status_)
        return [report.study_out(s, st, with_document=False) for st in s.execute(q).scalars()]


@router.get("/{study_id}", response_model=StudyOut, responses=_404)
def get_study(study_id: int = StudyId, db: Database = Depends(get_db)):
    with db.read() as s:
        return report.study_out(s, _study(s, study_id))


@router.get("/{study_id}/trials", response_model=list[TrialOut], responses=_404)
def get_trials(study_id: int = StudyId, db: Database = Depends(get_db)):
    with db.read() as s:
        return report.trials(s, _study(s, study_id))


@router.get("/{study_id}/trials.csv", response_class=Response, responses={200: {"content": {"text/csv": {}}}, **_404})
def get_trials_csv(study_id: int = StudyId, db: Database = Depends(get_db)):
    with db.read() as s:
        text = report.trials_csv(report.trials(s, _study(s, study_id)))
    return Response(text, media_type="text/csv",
                    headers={"Content-Disposition": f'attachment; filename="study-{study_id}-trials.csv"'})


@router.post("/{study_id}/cancel", response_model=StudyOut, dependencies=[Depends(require_token)],
             responses={**_404, 400: {"description": "invalid Content-Length"}, 401: {"description": "token required"},
                        413: {"description": "body too large"}})
def cancel_study(study_id: int = StudyId, db: Database = Depends(get_db)):
    """Cancel queued jobs at once; running jobs stop at their worker's next heartbeat."""
    if not queue.cancel_study(db, study_id):
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail=f"study {study_id} not found")
    with db.read() as s:
        return report.study_out(s, _study(s, study_id))
