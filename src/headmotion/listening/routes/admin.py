"""The admin API: log in and out (session cookie, CSRF double submit), progress, and the results
as JSON or CSV.  The token is accepted in ``Authorization: Bearer`` or ``X-Admin-Token``
(scripts) or as the session cookie (the admin page); never in the URL."""

from __future__ import annotations

import secrets

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, ConfigDict, Field

from ..guard import CSRF_COOKIE, SESSION_COOKIE
from ..results_export import results_csv, results_document
from . import ServerContext, server_context

router = APIRouter()


class SessionBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    token: str = Field(max_length=512)


def require_admin(ctx: ServerContext, request: Request) -> None:
    """401 unless the request carries the admin token in a header or the session cookie."""
    given = request.headers.get("x-admin-token") or ""
    auth = request.headers.get("authorization", "")
    if auth.lower().startswith("bearer "):
        given = auth[7:].strip()
    if given and secrets.compare_digest(given.encode(), ctx.token.encode()):
        return
    cookie = request.cookies.get(SESSION_COOKIE, "")
    if cookie and secrets.compare_digest(cookie.encode(), ctx.session_value.encode()):
        return
    raise HTTPException(status_code=401, detail="admin token required")


def require_csrf(request: Request) -> None:
    """Admin POSTs: the ``X-CSRF-Token`` header must equal the ``hm_csrf`` cookie (a page on
    another site can neither read the cookie nor set the header) — Guard has checked
    ``Origin`` already."""
    cookie = request.cookies.get(CSRF_COOKIE, "")
    header = request.headers.get("x-csrf-token", "")
    if not cookie or not header or not secrets.compare_digest(cookie.encode(), header.encode()):
        raise HTTPException(status_code=403, detail="missing or wrong CSRF token")


@router.post("/api/admin/session")
def admin_login(body: SessionBody, request: Request, ctx: ServerContext = Depends(server_context)):
    require_csrf(request)
    if not secrets.compare_digest(body.token.encode(), ctx.token.encode()):
        raise HTTPException(status_code=401, detail="wrong admin token")
    resp = JSONResponse({"ok": True})
    ctx.set_session(resp, request.url.scheme == "https")
    return resp


@router.post("/api/admin/logout")
def admin_logout(request: Request):
    require_csrf(request)
    resp = JSONResponse({"ok": True})
    resp.delete_cookie(SESSION_COOKIE, path="/", samesite="strict", httponly=True)
    return resp


@router.get("/api/admin/progress")
def admin_progress(request: Request, ctx: ServerContext = Depends(server_context)):
    require_admin(ctx, request)
    ps = ctx.db.progress()
    return {"test": ctx.cfg.name, "type": ctx.cfg.type, "participants": ps,
            "n_participants": len(ps), "n_finished": sum(p["stage"] == "done" for p in ps),
            "n_answers": ctx.db.count_answers()}


@router.get("/api/admin/results.json")
def admin_json(request: Request, ctx: ServerContext = Depends(server_context)):
    require_admin(ctx, request)
    return JSONResponse(results_document(ctx.cfg, ctx.db),
                        headers={"Content-Disposition":
                                 f'attachment; filename="{ctx.cfg.name}-results.json"'})


@router.get("/api/admin/results.csv")
def admin_csv(request: Request, ctx: ServerContext = Depends(server_context)):
    require_admin(ctx, request)
    return Response(results_csv(ctx.db), media_type="text/csv",
                    headers={"Content-Disposition":
                             f'attachment; filename="{ctx.cfg.name}-results.csv"'})
