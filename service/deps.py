"""FastAPI dependencies: settings, the store, bearer token for writes."""

from __future__ import annotations

import hmac

from fastapi import Depends, HTTPException, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from store import Store

from .config import Settings

_bearer = HTTPBearer(auto_error=False, description="FIBRECUT_API_TOKEN; required for writes when the server sets it")


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


def get_db(request: Request) -> Store:
    return request.app.state.db


def require_token(creds: HTTPAuthorizationCredentials | None = Depends(_bearer), settings: Settings = Depends(get_settings)) -> None:
    if not settings.api_token:
        return
    if creds is None or not hmac.compare_digest(creds.credentials.encode(), settings.api_token.encode()):
        raise HTTPException(status.HTTP_401_UNAUTHORIZED, detail="a valid bearer token is required for writes (FIBRECUT_API_TOKEN)",
                            headers={"WWW-Authenticate": "Bearer"})
