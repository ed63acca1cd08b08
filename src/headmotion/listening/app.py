"""The listening-test web app (FastAPI): participants rate head-motion stimuli in the browser
(thesis §4.2.3–4.2.4 MOS with reference, §5.5.1 A/B forced choice; paper §4.4 MUSHRA).

Participant flow: consent → demographics questionnaire (configurable) → instructions → training
trials (stored, flagged ``phase='training'``) → test trials in a per-participant seeded random
order (with optional attention checks) → thank-you page.  The participant's token lives in the
browser's localStorage, so closing the tab and coming back resumes at the next unanswered trial.
The server only ever accepts an answer for the participant's *next* trial, so a rating cannot be
changed once given.

The browser never sees system names or file paths: stimuli are addressed by opaque ids and
conditions by slot letters (A, B, ... / left, right); the mapping stays on the server.

Admin API: ``/api/admin/progress``, ``/api/admin/results.json``, ``/api/admin/results.csv``; page
``/admin``.  The token is accepted in ``Authorization: Bearer`` or ``X-Admin-Token`` (scripts) or as
the admin session cookie: the link ``/admin?token=...`` printed by ``listen serve`` is used once —
the server sets an ``HttpOnly; SameSite=Strict`` cookie holding a keyed hash of the token and
redirects to ``/admin``, so the token leaves the address bar and the history.  The page's login
form posts to ``/api/admin/session``; admin POSTs need the ``X-CSRF-Token`` header to equal the
``hm_csrf`` cookie (double submit) and a same-origin ``Origin``.

Hardening, one ASGI middleware (:class:`Guard`) in front of everything:

* **Host allow-list** — a request whose ``Host`` is not an allowed name gets 400, so a page on
  another site cannot reach the server through DNS rebinding.  Allowed: ``localhost``,
  ``127.0.0.1``, ``::1``, the served host and every ``--allowed-host`` (Starlette's
  ``TrustedHostMiddleware`` was considered; it splits ``[::1]:8000`` at the first colon and so
  refuses every IPv6 literal).
* **Headers on every response** — ``Content-Security-Policy`` (same-origin scripts, styles, media
  and connections; ``frame-ancestors 'none'``; ``object-src 'none'``; ``base-uri 'none'``),
  ``X-Frame-Options: DENY``, ``X-Content-Type-Options: nosniff``, ``Referrer-Policy: no-referrer``,
  ``Cross-Origin-Opener-Policy: same-origin``; ``Cache-Control: no-store`` on the API.
* **Request bodies** over ``max_body`` bytes (default 64 KiB) get 413 — by ``Content-Length`` or
  while a chunked body streams in.
* **Cross-site writes** — a POST whose ``Origin`` is not this server gets 403.
* **Registration** — at most ``registrations_per_address`` new participants per client address
  per ``registration_window_s`` (429; loopback addresses — participants at the experimenter's own
  machine — are not limited) and at most ``max_participants`` in all (403 "full"), both from the
  configuration and both counted in the database, so they hold over several workers.

Speed (target: answer p95 ≤ 250 ms with 300 participants answering every 50 ms): the
state read and the answer — the two requests of every trial — are served by plain ASGI code
(:mod:`headmotion.listening.trials_api`) in front of FastAPI, and on SQLite every write goes
through one group-commit thread per process (:mod:`headmotion.listening.sqlite_writer`); the
participant API's FastAPI handlers are coroutines.  ``benchmarks/run.py --only server`` measures it.

Libraries considered: webMUSHRA and HEMVIP (PHP/JS test frameworks for audio and gesture; not
embeddable in a Python package, no head viewer), Flask (no request validation built in).
"""

from __future__ import annotations

import csv
import hashlib
import hmac
import io
import json
import math
import os
import secrets
import socket
import time
from pathlib import Path
from typing import Any

from fastapi import FastAPI, HTTPException, Request
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, RedirectResponse, Response
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, ConfigDict, Field

from .config import TestConfig
from .db import ANSWER_COLUMNS, Conflict, Database, Full, NotFound, RateLimited
from .plan import make_plan, unblind_id
from .trials_api import TrialEndpoints
from .trials_api import bad as _bad

STATIC = Path(__file__).resolve().parent / "static"
VIEWER_STATIC = Path(__file__).resolve().parents[1] / "web" / "static"
MEDIA_TYPES = {".mp4": "video/mp4", ".m4v": "video/mp4", ".webm": "video/webm",
               ".ogv": "video/ogg", ".wav": "audio/wav", ".mp3": "audio/mpeg",
               ".ogg": "audio/ogg", ".flac": "audio/flac", ".m4a": "audio/mp4"}


class ConsentBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    consent: bool


class DemographicsBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    answers: dict[str, str | int | float | None] = Field(default_factory=dict)


CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
       "media-src 'self' blob:; connect-src 'self'; worker-src 'self' blob:; font-src 'self'; "
       "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")
SECURITY_HEADERS = [
    (b"content-security-policy", CSP.encode()),
    (b"x-frame-options", b"DENY"),
    (b"x-content-type-options", b"nosniff"),
    (b"referrer-policy", b"no-referrer"),
    (b"cross-origin-opener-policy", b"same-origin"),
]
_REPLACED = frozenset(name for name, _ in SECURITY_HEADERS)  # the app's own values are replaced
_API_HEADERS = [*SECURITY_HEADERS, (b"cache-control", b"no-store")]
_API_REPLACED = frozenset(name for name, _ in _API_HEADERS)
MAX_BODY = 64 * 1024
SESSION_COOKIE = "hm_admin"
CSRF_COOKIE = "hm_csrf"


def split_host(value: str) -> str:
    """The host name of a ``Host`` header (``name``, ``name:port``, ``[v6]`` or ``[v6]:port``),
    lower-case, without a trailing dot."""
    v = value.strip().lower()
    if v.startswith("["):
        end = v.find("]")
        return v[1:end] if end > 0 else ""
    if v.count(":") == 1:
        v = v.split(":", 1)[0]
    return v.rstrip(".")


def _is_loopback(addr: str) -> bool:
    import ipaddress

    try:
        return ipaddress.ip_address(addr).is_loopback
    except ValueError:
        return False


def default_allowed_hosts(served: str | None = None) -> set[str]:
    """``localhost`` and the loopback addresses, plus ``served`` (the ``--host``) — and, when
    it is a wildcard (0.0.0.0 / ::), this machine's host names and their addresses."""
    hosts = {"localhost", "127.0.0.1", "::1"}
    if served and served not in ("0.0.0.0", "::", ""):
        hosts.add(split_host(served) if served.startswith("[") else served.lower())
    elif served in ("0.0.0.0", "::"):
        for name in {socket.gethostname(), socket.getfqdn()}:
            if name:
                hosts.add(name.lower())
                try:
                    hosts.update(socket.gethostbyname_ex(name)[2])
                except OSError:
                    pass
    return hosts


class Guard:
    """ASGI middleware: Host allow-list, body-size limit, same-origin writes, security headers
    (see the module docstring)."""

    def __init__(self, app, *, allowed_hosts: set[str], max_body: int = MAX_BODY):
        self.app, self.allowed, self.max_body = app, {h.lower() for h in allowed_hosts}, max_body

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = dict(scope.get("headers") or [])
        host = headers.get(b"host", b"").decode("latin-1")
        if split_host(host) not in self.allowed:
            return await _plain(send, 400, "host not allowed (start the server with --allowed-host NAME "
                                           "to serve this name)")
        method = scope.get("method", "GET")
        if method not in ("GET", "HEAD", "OPTIONS"):
            origin = headers.get(b"origin")
            if origin is not None and origin != b"null":
                o = origin.decode("latin-1")
                o_host = o.split("://", 1)[-1]
                if o_host.lower() != host.lower():
                    return await _plain(send, 403, "cross-origin request refused")
            elif origin == b"null":
                return await _plain(send, 403, "cross-origin request refused")
        length = headers.get(b"content-length")
        if length is not None:
            try:
                too_big = int(length) > self.max_body
            except ValueError:
                return await _plain(send, 400, "bad Content-Length")
            if too_big:
                return await _plain(send, 413, f"request body larger than {self.max_body} bytes")
        api = scope.get("path", "").startswith("/api/")
        seen = 0
        started = refused = False

        async def limited_receive():
            nonlocal seen, refused
            if refused:
                return {"type": "http.disconnect"}
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > self.max_body:  # a streamed body over the limit: answer 413 ourselves
                    refused = True
                    if not started:
                        await _plain(send, 413, f"request body larger than {self.max_body} bytes")
                    return {"type": "http.disconnect"}
            return msg

        async def send_with_headers(msg):
            nonlocal started
            if refused:  # the 413 has been sent; whatever the app answers is dropped
                return
            if msg["type"] == "http.response.start":
                started = True
                drop = _API_REPLACED if api else _REPLACED
                hs = [h for h in msg.get("headers", ()) if h[0].lower() not in drop]
                hs += _API_HEADERS if api else SECURITY_HEADERS
                msg = {**msg, "headers": hs}
            await send(msg)

        try:
            await self.app(scope, limited_receive, send_with_headers)
        except Exception:
            if not refused:
                raise


async def _plain(send, status: int, text: str) -> None:
    body = json.dumps({"detail": text}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode()), *SECURITY_HEADERS]})
    await send({"type": "http.response.body", "body": body})


class SessionBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    token: str = Field(max_length=512)


def create_app(cfg: TestConfig, *, database_url: str | None = None,
               admin_token: str | None = None, allowed_hosts=None, served_host: str | None = None,
               max_body: int = MAX_BODY, durable: bool = True):
    """Build the app for one test.

    Parameters
    ----------
    cfg : TestConfig
        From :func:`headmotion.listening.config.load_config`.
    database_url : str, optional
        Defaults to the config's ``database`` or ``sqlite:///<config folder>/results/<name>.sqlite``.
    admin_token : str, optional
        Defaults to the config's ``admin_token``, then ``$HEADMOTION_ADMIN_TOKEN``, then a random
        token (available as ``app.state.admin_token``).
    allowed_hosts : iterable of str, optional
        Host names accepted in the ``Host`` header besides :func:`default_allowed_hosts` of
        ``served_host`` (the address the server listens on).
    max_body : int
        Largest request body accepted (bytes).
    durable : bool
        SQLite: ``synchronous=FULL`` (default; an acknowledged answer survives a power cut: each
        commit is fsynced before its answers are acknowledged, answers arriving together sharing
        one commit) or ``NORMAL`` (survives a killed server, not a power cut; commits not fsynced).

    Returns the ASGI app (the FastAPI app wrapped in :class:`Guard`); the FastAPI app's state
    (``cfg``, ``db``, ``admin_token``, ``database_url``, ``allowed_hosts``) is on ``.state`` of
    both.
    """
    url = database_url or cfg.database or cfg.default_database_url()
    db = Database(url, durable=durable)
    previous = db.get_meta("config")
    if previous and previous.get("digest") != cfg.digest and db.progress():
        import warnings

        warnings.warn(f"the configuration {cfg.path} changed since participants started this test "
                      f"(database {url}); their stored trial order is kept", stacklevel=2)
    db.set_meta("config", {"name": cfg.name, "type": cfg.type, "digest": cfg.digest,
                           "path": str(cfg.path), "hidden_reference": cfg.hidden_reference,
                           "anchor": cfg.anchor, "screening_threshold": cfg.screening_threshold,
                           "screening_fraction": cfg.screening_fraction,
                           "scale_points": cfg.scale_points,
                           "demographics": [q.name for q in cfg.demographics]})
    secret_hex = db.get_or_set_meta("secret", lambda: secrets.token_hex(32))
    secret = bytes.fromhex(secret_hex)
    token = admin_token or cfg.admin_token or os.environ.get("HEADMOTION_ADMIN_TOKEN") \
        or secrets.token_urlsafe(16)

    app = FastAPI(title=f"headmotion listening test: {cfg.title}", docs_url=None, redoc_url=None,
                  openapi_url=None, **_no_telemetry())
    app.state.cfg = cfg
    app.state.db = db
    app.state.admin_token = token
    app.state.database_url = url
    motion_cache: dict[str, bytes] = {}
    session_value = hmac.new(secret, b"admin-session:" + token.encode(), hashlib.sha256).hexdigest()
    hosts = default_allowed_hosts(served_host) | {split_host(h) for h in (allowed_hosts or ()) if h}
    app.state.allowed_hosts = hosts

    # -- pages -----------------------------------------------------------------------------
    @app.get("/", response_class=HTMLResponse)
    def index():
        return FileResponse(STATIC / "index.html", media_type="text/html")

    @app.get("/admin", response_class=HTMLResponse)
    def admin_page(request: Request):
        secure = request.url.scheme == "https"
        given = request.query_params.get("token")
        if given is not None:  # the printed link: trade the token for a cookie, clean the URL
            resp = RedirectResponse("/admin", status_code=303)
            if secrets.compare_digest(given.encode(), token.encode()):
                _set_session(resp, secure)
            resp.headers["Cache-Control"] = "no-store"
            return resp
        resp = FileResponse(STATIC / "admin.html", media_type="text/html")
        if not request.cookies.get(CSRF_COOKIE):
            resp.set_cookie(CSRF_COOKIE, secrets.token_urlsafe(24), httponly=False, samesite="strict",
                            secure=secure, path="/")
        return resp

    def _set_session(resp: Response, secure: bool) -> None:
        resp.set_cookie(SESSION_COOKIE, session_value, httponly=True, samesite="strict", secure=secure,
                        path="/")

    @app.get("/favicon.ico")
    def favicon():
        return Response(status_code=204)

    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    if VIEWER_STATIC.is_dir():
        app.mount("/viewer", StaticFiles(directory=VIEWER_STATIC), name="viewer")

    # -- participant API -------------------------------------------------------------------
    @app.get("/api/test")
    def test_info():
        info = cfg.public_info()
        info["viewer"] = _viewer_module()
        return info

    # the participant API's handlers are coroutines: their database calls go to the SQLite writer
    # thread (or, on PostgreSQL, a worker thread), not through FastAPI's thread pool
    @app.post("/api/participants", status_code=201)
    async def register(body: ConsentBody, request: Request):
        if not body.consent:
            _bad("consent is required to take part", 400)
        first = "demographics" if cfg.demographics else "instructions"
        client = request.client.host if request.client else ""
        # the lab machine itself (participants at the experimenter's computer) is not limited
        addr = "" if _is_loopback(client) else \
            hmac.new(secret, b"addr:" + client.encode(), hashlib.sha256).hexdigest()[:32]
        try:
            p = await db.create_participant_async(
                lambda n: make_plan(cfg, n), user_agent=request.headers.get("user-agent", ""),
                stage=first, addr=addr, max_participants=cfg.max_participants,
                per_address=cfg.registrations_per_address, window_s=cfg.registration_window_s)
        except Full:
            raise HTTPException(status_code=403, detail="this test is full; thank you for your "
                                                        "interest") from None
        except RateLimited:
            raise HTTPException(status_code=429, detail="too many registrations from this address; "
                                                        "try again later",
                                headers={"Retry-After": str(int(cfg.registration_window_s))}) from None
        return {"token": p["token"], "stage": p["stage"]}

    async def _known(token: str) -> None:
        """404 for a token that names no participant (the plan is cached after the first look)."""
        try:
            await db.plan_async(token)
        except NotFound:
            raise HTTPException(status_code=404, detail="unknown participant") from None

    @app.post("/api/p/{token}/demographics")
    async def demographics(token: str, body: DemographicsBody):
        await _known(token)
        clean = _check_demographics(cfg, body.answers)
        await _advance(token, "demographics", "instructions", demographics=clean)
        return {"stage": "instructions"}

    @app.post("/api/p/{token}/start")
    async def start(token: str):
        await _known(token)
        await _advance(token, "instructions", "trials")
        return {"stage": "trials"}

    async def _advance(token: str, expect: str, stage: str, **kw):
        try:
            await db.set_stage_async(token, expect=expect, stage=stage, **kw)
        except NotFound:
            raise HTTPException(status_code=404, detail="unknown participant") from None
        except Conflict as exc:
            raise HTTPException(status_code=409, detail=str(exc)) from None

    # -- stimuli ---------------------------------------------------------------------------
    @app.get("/stimuli/{alias}/{kind}")
    def stimulus(alias: str, kind: str):
        sid = unblind_id(alias, secret)
        stim = cfg.stimuli.get(sid) if sid else None
        if stim is None or kind not in stim.files():
            raise HTTPException(status_code=404, detail="unknown stimulus")
        path = stim.files()[kind].resolve()
        if not path.is_relative_to(cfg.root) or not path.is_file():  # symlinks out, or deleted
            raise HTTPException(status_code=404, detail="unknown stimulus")
        if kind == "motion":
            if sid not in motion_cache:
                motion_cache[sid] = json.dumps(_motion_json(path)).encode()
            return Response(motion_cache[sid], media_type="application/json",
                            headers={"Cache-Control": "max-age=3600"})
        return FileResponse(path, media_type=MEDIA_TYPES.get(path.suffix.lower(),
                                                             "application/octet-stream"),
                            headers={"Cache-Control": "max-age=3600"})

    # -- admin -----------------------------------------------------------------------------
    def _require_admin(request: Request):
        """The token in a header (scripts) or the session cookie (the admin page); never in
        the URL."""
        given = request.headers.get("x-admin-token") or ""
        auth = request.headers.get("authorization", "")
        if auth.lower().startswith("bearer "):
            given = auth[7:].strip()
        if given and secrets.compare_digest(given.encode(), token.encode()):
            return
        cookie = request.cookies.get(SESSION_COOKIE, "")
        if cookie and secrets.compare_digest(cookie.encode(), session_value.encode()):
            return
        raise HTTPException(status_code=401, detail="admin token required")

    def _require_csrf(request: Request):
        """Admin POSTs: the ``X-CSRF-Token`` header must equal the ``hm_csrf`` cookie (a page on
        another site can neither read the cookie nor set the header) — Guard has checked
        ``Origin`` already."""
        cookie = request.cookies.get(CSRF_COOKIE, "")
        header = request.headers.get("x-csrf-token", "")
        if not cookie or not header or not secrets.compare_digest(cookie.encode(), header.encode()):
            raise HTTPException(status_code=403, detail="missing or wrong CSRF token")

    @app.post("/api/admin/session")
    def admin_login(body: SessionBody, request: Request):
        _require_csrf(request)
        if not secrets.compare_digest(body.token.encode(), token.encode()):
            raise HTTPException(status_code=401, detail="wrong admin token")
        resp = JSONResponse({"ok": True})
        _set_session(resp, request.url.scheme == "https")
        return resp

    @app.post("/api/admin/logout")
    def admin_logout(request: Request):
        _require_csrf(request)
        resp = JSONResponse({"ok": True})
        resp.delete_cookie(SESSION_COOKIE, path="/", samesite="strict", httponly=True)
        return resp

    @app.get("/api/admin/progress")
    def admin_progress(request: Request):
        _require_admin(request)
        ps = db.progress()
        return {"test": cfg.name, "type": cfg.type, "participants": ps,
                "n_participants": len(ps), "n_finished": sum(p["stage"] == "done" for p in ps),
                "n_answers": db.count_answers()}

    @app.get("/api/admin/results.json")
    def admin_json(request: Request):
        _require_admin(request)
        return JSONResponse(results_document(cfg, db),
                            headers={"Content-Disposition":
                                     f'attachment; filename="{cfg.name}-results.json"'})

    @app.get("/api/admin/results.csv")
    def admin_csv(request: Request):
        _require_admin(request)
        return Response(results_csv(db), media_type="text/csv",
                        headers={"Content-Disposition":
                                 f'attachment; filename="{cfg.name}-results.csv"'})

    # the state and answer requests of every trial skip FastAPI (see trials_api)
    trials = TrialEndpoints(app, cfg=cfg, db=db, secret=secret)
    guarded = Guard(trials, allowed_hosts=hosts, max_body=max_body)
    guarded.state = app.state
    return guarded


def _no_telemetry() -> dict[str, Any]:
    """FastAPI's keyword that turns its OpenTelemetry instrumentation off, where it has one: newer
    FastAPI looks up the tracer, meter and logger providers on every request (~6% of the server's
    CPU under load), and this server exports no telemetry."""
    import inspect

    if "telemetry" in inspect.signature(FastAPI.__init__).parameters:
        return {"telemetry": {"tracing": False, "metrics": False, "logs": False,
                              "operation_spans": False}}
    return {}


def app_from_env():
    """Factory for ``uvicorn --factory`` worker processes (``listen serve --workers N``): the
    settings come from ``HEADMOTION_LISTEN_CONFIG``, ``HEADMOTION_LISTEN_DATABASE``,
    ``HEADMOTION_ADMIN_TOKEN``, ``HEADMOTION_LISTEN_ALLOWED_HOSTS`` (comma-separated),
    ``HEADMOTION_LISTEN_HOST`` and ``HEADMOTION_LISTEN_SYNC``, set by the parent process."""
    from .config import load_config

    cfg = load_config(os.environ["HEADMOTION_LISTEN_CONFIG"])
    hosts = [h for h in os.environ.get("HEADMOTION_LISTEN_ALLOWED_HOSTS", "").split(",") if h]
    return create_app(cfg, database_url=os.environ.get("HEADMOTION_LISTEN_DATABASE") or None,
                      admin_token=os.environ.get("HEADMOTION_ADMIN_TOKEN") or None,
                      allowed_hosts=hosts, served_host=os.environ.get("HEADMOTION_LISTEN_HOST"),
                      durable=os.environ.get("HEADMOTION_LISTEN_SYNC", "full") != "normal")


def _viewer_module() -> str | None:
    """URL of the viewer component's ES module, if the web viewer is installed."""
    for name in ("viewer.js", "headviewer.js", "head-viewer.js", "index.js"):
        if (VIEWER_STATIC / name).is_file():
            return f"/viewer/{name}"
    return None


def _check_demographics(cfg: TestConfig, given: dict[str, Any]) -> dict[str, Any]:
    known = {q.name: q for q in cfg.demographics}
    for k in given:
        if k not in known:
            _bad(f"unknown demographics question {k!r}")
    clean: dict[str, Any] = {}
    for q in cfg.demographics:
        v = given.get(q.name)
        if v is None or (isinstance(v, str) and not v.strip()):
            if q.required:
                _bad(f"please answer {q.label!r}")
            continue
        if q.type == "choice":
            if str(v) not in q.options:
                _bad(f"{q.label!r} must be one of {list(q.options)}; got {v!r}")
            v = str(v)
        elif q.type == "number":
            try:
                v = float(v)
            except (TypeError, ValueError):
                _bad(f"{q.label!r} must be a number; got {v!r}")
            if not math.isfinite(v):
                _bad(f"{q.label!r} must be a finite number")
        else:
            v = str(v)[:500]
        clean[q.name] = v
    return clean


def _motion_json(path: Path) -> dict[str, Any]:
    """A motion file as ``{"fps", "rotvec": [[x, y, z], ...]}`` for the browser viewer."""
    try:
        from ..io import load_motion  # the motion-format owner's reader, when present
    except ImportError:
        load_motion = None
    if load_motion is not None:
        m = load_motion(path)
        rotvec, fps = m.rotvec, m.fps
    else:
        import numpy as np

        if path.suffix.lower() == ".npz":
            with np.load(path, allow_pickle=False) as z:
                rotvec, fps = np.asarray(z["rotvec"], float), float(z["fps"])
        else:
            d = json.loads(path.read_text())
            rotvec, fps = np.asarray(d["rotvec"], float), float(d["fps"])
    return {"fps": float(fps), "rotvec": [[round(float(v), 6) for v in r] for r in rotvec]}


def results_document(cfg: TestConfig, db: Database) -> dict[str, Any]:
    """Everything the analysis needs: test settings, participants (demographics) and answers."""
    return {
        "format": "headmotion-listening-results/1",
        "exported_at": time.time(),
        "test": {"name": cfg.name, "type": cfg.type, "title": cfg.title, "digest": cfg.digest,
                 "scale_points": cfg.scale_points, "hidden_reference": cfg.hidden_reference,
                 "anchor": cfg.anchor, "screening_threshold": cfg.screening_threshold,
                 "screening_fraction": cfg.screening_fraction,
                 "demographics": [q.name for q in cfg.demographics]},
        "participants": db.progress(),
        "answers": db.answer_rows(),
    }


def results_csv(db: Database) -> str:
    rows = db.answer_rows()
    demo = sorted({k for r in rows for k in r if k.startswith("demo_")})
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(ANSWER_COLUMNS) + demo, extrasaction="ignore",
                       lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    return buf.getvalue()


__all__ = ["create_app", "app_from_env", "default_allowed_hosts", "Guard", "results_document",
           "results_csv"]
