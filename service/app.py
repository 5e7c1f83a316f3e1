"""The FastAPI application: routers, error handlers, body limit, the dashboard.

``create_app(settings)`` wires the pieces; it holds no business logic. Study validation
problems (:class:`service.studies.StudyError`, which carries solver ``SceneError`` problems)
answer 422 with FastAPI's error shape: ``loc`` is the path in the body with the dotted
scene field as one element, and ``field`` the dotted name.
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse
from starlette.middleware.base import BaseHTTPMiddleware

from .config import Settings
from .db import get_database
from .routers import misc, runs, studies as studies_router
from .studies import StudyError

WEB_DIR = Path(__file__).resolve().parent.parent / "web"


class BodyLimit(BaseHTTPMiddleware):
    """413 for bodies above the limit (declared length, or counted while reading)."""

    def __init__(self, app, max_bytes: int):
        super().__init__(app)
        self.max_bytes = max_bytes

    async def dispatch(self, request: Request, call_next):
        if request.method in ("POST", "PUT", "PATCH"):
            declared = request.headers.get("content-length")
            too_big = JSONResponse({"detail": f"request body above the limit of {self.max_bytes} bytes"}, status_code=413)
            if declared is not None:
                try:
                    if int(declared) > self.max_bytes:
                        return too_big
                except ValueError:
                    return JSONResponse({"detail": "invalid Content-Length"}, status_code=400)
            else:
                body = b""
                async for chunk in request.stream():
                    body += chunk
                    if len(body) > self.max_bytes:
                        return too_big
                request._body = body
        return await call_next(request)


def create_app(settings: Settings | None = None, migrate: bool = True) -> FastAPI:
    settings = settings or Settings.from_env()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    settings.runs_dir.mkdir(parents=True, exist_ok=True)
    if migrate:
        from .migrate import upgrade

        upgrade(settings.db_url)
    app = FastAPI(title="fibrecut", version="0.1.0",
                  description="Studies (sweeps, optimisations, convergence) of orthogonal CFRP cutting on a worker pool.")
    app.state.settings = settings
    app.state.db = get_database(settings.db_url)
    app.add_middleware(BodyLimit, max_bytes=settings.limits.max_body_bytes)

    @app.exception_handler(StudyError)
    async def _study_error(_request: Request, exc: StudyError):
        detail = [{"type": "value_error", "loc": ["body", *p.loc], "field": p.field, "msg": p.message, "input": _safe(p.value)}
                  for p in exc.problems]
        return JSONResponse({"detail": detail}, status_code=422)

    app.include_router(studies_router.router)
    app.include_router(studies_router.measurements_router)
    app.include_router(runs.router)
    app.include_router(misc.router)
    try:  # the dashboard's read-only extras (run context, mesh), written with the dashboard (issue 7)
        from . import api_web
    except ImportError:  # pragma: no cover - the dashboard extras are optional
        api_web = None
    if api_web is not None:
        app.include_router(api_web.router)

    static = WEB_DIR / "static"
    if static.is_dir():
        from fastapi.staticfiles import StaticFiles

        app.mount("/static", StaticFiles(directory=static), name="static")

    @app.get("/", include_in_schema=False)
    def index():
        page = WEB_DIR / "index.html"
        if page.is_file():
            return FileResponse(page, media_type="text/html")
        return HTMLResponse("<!doctype html><title>fibrecut</title><h1>fibrecut</h1>"
                            "<p>The dashboard is not built (web/index.html is missing). The API is at <a href='/docs'>/docs</a>.</p>")

    return app


def _safe(v):
    import json

    try:
        json.dumps(v, allow_nan=False)
        return v
    except (TypeError, ValueError):
        return str(v)
