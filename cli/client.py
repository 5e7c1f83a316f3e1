"""A small REST client for the CLI: URL and token from options or FIBRECUT_URL / FIBRECUT_API_TOKEN."""

from __future__ import annotations

import os
from typing import Any

import httpx

DEFAULT_URL = "http://127.0.0.1:8000"


class ApiError(Exception):
    def __init__(self, status: int, message: str):
        self.status = status
        super().__init__(message)


class Client:
    def __init__(self, url: str | None = None, token: str | None = None, timeout: float = 30.0):
        self.url = (url or os.environ.get("FIBRECUT_URL") or DEFAULT_URL).rstrip("/")
        token = token or os.environ.get("FIBRECUT_API_TOKEN")
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.http = httpx.Client(base_url=self.url, headers=headers, timeout=timeout)

    def _check(self, r: httpx.Response) -> Any:
        if r.status_code < 400:
            return r.json() if r.headers.get("content-type", "").startswith("application/json") else r.text
        try:
            detail = r.json().get("detail")
        except ValueError:
            detail = r.text
        raise ApiError(r.status_code, format_detail(detail))

    def request(self, method: str, path: str, **kw) -> Any:
        try:
            return self._check(self.http.request(method, path, **kw))
        except httpx.TransportError as exc:
            raise ApiError(0, f"cannot reach the fibrecut service at {self.url} ({exc}); start it with 'fibrecut serve' "
                              "or give --url / FIBRECUT_URL") from None

    def submit(self, doc: dict) -> dict:
        return self.request("POST", "/api/studies", json=doc)

    def study(self, study_id: int) -> dict:
        return self.request("GET", f"/api/studies/{study_id}")

    def studies(self) -> list[dict]:
        return self.request("GET", "/api/studies")

    def trials(self, study_id: int) -> list[dict]:
        return self.request("GET", f"/api/studies/{study_id}/trials")

    def trials_csv(self, study_id: int) -> str:
        return self.request("GET", f"/api/studies/{study_id}/trials.csv")

    def cancel(self, study_id: int) -> dict:
        return self.request("POST", f"/api/studies/{study_id}/cancel")


def format_detail(detail: Any) -> str:
    """FastAPI's 422 detail list as one line: ``field = value: what is allowed``."""
    if isinstance(detail, list):
        parts = []
        for d in detail:
            if not isinstance(d, dict):
                parts.append(str(d))
                continue
            loc = d.get("field") or ".".join(str(x) for x in d.get("loc", []) if x != "body")
            value = d.get("input")
            shown = f" = {value!r}" if value is not None and not isinstance(value, dict) else ""
            parts.append(f"{loc}{shown}: {d.get('msg')}")
        return "; ".join(parts)
    return str(detail)
