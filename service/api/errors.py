"""Every error is JSON: `{"detail": "<one line naming the field or reason>", "errors": [...]}`."""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match

from registry.errors import (
    InvalidName,
    InvalidRunDirectory,
    PathOutsideRoot,
    PolicyNotFound,
    RegistryError,
    VersionNotFound,
)
from service.errors import ServiceError
from service.schemas.jobs import JobKindName

log = logging.getLogger("dualsys.service.api")
_KINDS = set(JobKindName.__args__)  # type: ignore[attr-defined]
_LOCATIONS = {"body", "query", "path", "header", "cookie"}
HTTP_METHODS = ("DELETE", "GET", "HEAD", "OPTIONS", "PATCH", "POST", "PUT")


def field_path(loc: tuple[Any, ...] | list[Any]) -> str:
    """`('body', 'train', 'spec', 'episodes')` → `spec.episodes` (drops the location and union tag)."""
    parts = list(loc)
    if parts and parts[0] in _LOCATIONS:
        where = parts.pop(0)
        if where == "body" and parts and parts[0] in _KINDS and len(parts) > 1:
            parts.pop(0)
    text = ".".join(str(p) for p in parts if not (isinstance(p, str) and p.startswith("function-")))
    return text or "body"


def error_body(detail: str, errors: list[dict[str, str]] | None = None) -> dict[str, Any]:
    return {"detail": detail, "errors": errors or []}


def _registry_status(error: RegistryError) -> int:
    if isinstance(error, PolicyNotFound | VersionNotFound):
        return 404
    if isinstance(error, PathOutsideRoot):
        return 400
    if isinstance(error, InvalidName | InvalidRunDirectory):
        return 422
    return 400


def allowed_methods(request: Request) -> str:
    """Every method some route serves at the request's path, for a 405's `Allow` header.

    Starlette names only the methods of the first route whose path matched (`POST` for `/jobs`, where
    `GET` is served by a second route); a client that trusts `Allow` must see them all. Each method is
    tried against the routes' own `matches` (FastAPI nests included routers, so the routes' `methods`
    are not all on the top level).
    """
    found = []
    for method in HTTP_METHODS:
        scope = {**request.scope, "method": method}
        if any(route.matches(scope)[0] is Match.FULL for route in request.app.router.routes):
            found.append(method)
    return ", ".join(found)


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, error: RequestValidationError) -> JSONResponse:
        errors = []
        for item in error.errors():
            message = str(item.get("msg", "invalid value")).removeprefix("Value error, ")
            field = field_path(item.get("loc", ()))
            if item.get("type") in ("union_tag_invalid", "union_tag_not_found"):
                field = "kind" if field == "body" else f"{field}.kind"
            errors.append({"field": field, "message": message})
        first = errors[0] if errors else {"field": "body", "message": "invalid request"}
        detail = f"{first['field']}: {first['message']}"
        if len(errors) > 1:
            detail += f" (and {len(errors) - 1} more)"
        return JSONResponse(status_code=422, content=error_body(detail, errors))

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, error: StarletteHTTPException) -> JSONResponse:
        detail = error.detail if isinstance(error.detail, str) else str(error.detail)
        headers = error.headers
        if error.status_code == 405:
            headers = {**(headers or {}), "Allow": allowed_methods(request)}
        return JSONResponse(status_code=error.status_code, content=error_body(detail), headers=headers)

    @app.exception_handler(ServiceError)
    async def _service(request: Request, error: ServiceError) -> JSONResponse:
        errors = [{"field": error.field, "message": str(error)}] if error.field else []
        return JSONResponse(status_code=error.status_code, content=error_body(str(error), errors))

    @app.exception_handler(RegistryError)
    async def _registry(request: Request, error: RegistryError) -> JSONResponse:
        return JSONResponse(status_code=_registry_status(error), content=error_body(str(error)))

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, error: Exception) -> JSONResponse:
        log.exception("unhandled error on %s %s", request.method, request.url.path)
        return JSONResponse(status_code=500, content=error_body(f"internal error: {type(error).__name__}"))
