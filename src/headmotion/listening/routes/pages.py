"""The participant page, the admin page (which trades the printed admin link's token for the
session cookie) and the favicon."""

from __future__ import annotations

import secrets
from pathlib import Path

from fastapi import APIRouter, Depends, Request
from fastapi.responses import FileResponse, HTMLResponse, RedirectResponse, Response

from ..guard import CSRF_COOKIE
from . import ServerContext, server_context

STATIC = Path(__file__).resolve().parents[1] / "static"

router = APIRouter()


@router.get("/", response_class=HTMLResponse)
def index():
    return FileResponse(STATIC / "index.html", media_type="text/html")


@router.get("/admin", response_class=HTMLResponse)
def admin_page(request: Request, ctx: ServerContext = Depends(server_context)):
    secure = request.url.scheme == "https"
    given = request.query_params.get("token")
    if given is not None:  # the printed link: trade the token for a cookie, clean the URL
        resp = RedirectResponse("/admin", status_code=303)
        if secrets.compare_digest(given.encode(), ctx.token.encode()):
            ctx.set_session(resp, secure)
        resp.headers["Cache-Control"] = "no-store"
        return resp
    resp = FileResponse(STATIC / "admin.html", media_type="text/html")
    if not request.cookies.get(CSRF_COOKIE):
        resp.set_cookie(CSRF_COOKIE, secrets.token_urlsafe(24), httponly=False, samesite="strict",
                        secure=secure, path="/")
    return resp


@router.get("/favicon.ico")
def favicon():
    return Response(status_code=204)
