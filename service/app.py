"""The FastAPI application: routers, error handlers, body limit, the dashboard.

``create_app(settings)`` wires the pieces; it holds no business logic. Study validation
problems (:class:`solver.scene.SceneError`, the one field-error class of scenes and study
documents) answer 422 with FastAPI's error shape: ``loc`` is the path in the body with the dotted
scene field as one element, and ``field`` the dotted name.
"""

from __future__ import annotations

import re
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse
from starlette.middleware.base import BaseHTTPMiddleware

from solver.scene import SceneError
from store import get_database

from .config import Settings
from .inputs import jsonable, nonfinite_paths
from .routers import dashboard, misc, runs, studies as studies_router

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


class AllowHeader(BaseHTTPMiddleware):
    """A 405 lists in ``Allow`` every method the OpenAPI document gives the path (Starlette lists
    only the first matching route's)."""

    def __init__(self, app):
        super().__init__(app)
        self._paths: list[tuple[re.Pattern, set[str]]] | None = None

    def _methods(self, request: Request, path: str) -> set[str]:
        if self._paths is None:
            self._paths = [(re.compile("^" + re.sub(r"\\\{[^/]+?\\\}", "[^/]+", re.escape(p)) + "$"),
                            {m.upper() for m in item}) for p, item in request.app.openapi()["paths"].items()]
        return {m for rx, ms in self._paths if rx.match(path) for m in ms}

    async def dispatch(self, request: Request, call_next):
        response = await call_next(request)
        if response.status_code == 405:
            methods = self._methods(request, request.url.path)
            if methods:
                response.headers["allow"] = ", ".join(sorted(methods))
        return response


def create_app(settings: Settings | None = None, migrate: bool = True) -> FastAPI:
    settings = settings or Settings.from_env()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    settings.runs_dir.mkdir(parents=True, exist_ok=True)
    store = get_database(settings.db_url)
    if migrate:
        store.migrate()
    app = FastAPI(title="fibrecut", version="0.1.0",
                  description="Studies (sweeps, optimisations, convergence) of orthogonal CFRP cutting on a worker pool.")
    app.state.settings = settings
    app.state.db = store
    app.add_middleware(BodyLimit, max_bytes=settings.limits.max_body_bytes)
    app.add_middleware(AllowHeader)

    @app.exception_handler(SceneError)
    async def _study_error(_request: Request, exc: SceneError):
        detail = [{"type": "value_error", "loc": ["body", *p.loc], "field": p.field, "msg": p.message, "input": jsonable(p.value)}
                  for p in exc.problems]
        return JSONResponse({"detail": detail}, status_code=422)

    @app.exception_handler(RequestValidationError)
    async def _validation_error(_request: Request, exc: RequestValidationError):
        return JSONResponse({"detail": validation_detail(exc)}, status_code=422)

    app.include_router(studies_router.router)
    app.include_router(studies_router.measurements_router)
    app.include_router(runs.router)
    app.include_router(misc.router)
    app.include_router(dashboard.router)  # the dashboard's read-only extras (run context, mesh)

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


def validation_detail(exc: RequestValidationError) -> list[dict]:
    """FastAPI's 422 detail with every value JSON can carry: a NaN or Infinity in the body is
    reported once per place (``loc``, ``field``) as not a finite number, and never echoed as one."""
    out, seen = [], set()
    body = getattr(exc, "body", None)
    for path in nonfinite_paths(body) if body is not None else []:
        loc = ["body", *path]
        seen.add(tuple(loc))
        out.append({"type": "finite_number", "loc": loc, "field": ".".join(str(x) for x in path),
                    "msg": "must be a finite number: NaN and Infinity are not allowed (nor valid JSON)",
                    "input": jsonable(_at(body, path))})
    for err in exc.errors():
        loc = list(err.get("loc", ()))
        if any(tuple(loc[:len(s)]) == s for s in seen):
            continue  # the non-finite number is already reported at this place
        item = {"type": err.get("type"), "loc": jsonable(loc), "field": ".".join(str(x) for x in loc if x not in ("body", "query", "path")),
                "msg": err.get("msg"), "input": jsonable(err.get("input"))}
        out.append(item)
    return out


def _at(doc, path):
    for key in path:
        doc = doc[key]
    return doc
