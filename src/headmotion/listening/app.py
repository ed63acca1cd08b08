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

Hardening, one ASGI middleware (:class:`~headmotion.listening.guard.Guard`) in front of everything:

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

import os
import secrets
from typing import Any

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from .config import TestConfig
from .db import Database
from .guard import CSP, MAX_BODY, Guard, default_allowed_hosts, split_host
from .results_export import results_csv, results_document
from .routes import ServerContext, admin, pages, participants
from .trials_api import TrialEndpoints

STATIC = pages.STATIC
VIEWER_STATIC = participants.VIEWER_STATIC


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
    _record_config(cfg, db, url)
    secret = bytes.fromhex(db.get_or_set_meta("secret", lambda: secrets.token_hex(32)))
    token = admin_token or cfg.admin_token or os.environ.get("HEADMOTION_ADMIN_TOKEN") \
        or secrets.token_urlsafe(16)

    app = FastAPI(title=f"headmotion listening test: {cfg.title}", docs_url=None, redoc_url=None,
                  openapi_url=None, **_no_telemetry())
    app.state.cfg = cfg
    app.state.db = db
    app.state.admin_token = token
    app.state.database_url = url
    app.state.ctx = ServerContext(cfg=cfg, db=db, secret=secret, token=token)
    hosts = default_allowed_hosts(served_host) | {split_host(h) for h in (allowed_hosts or ()) if h}
    app.state.allowed_hosts = hosts

    app.include_router(pages.router)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    if VIEWER_STATIC.is_dir():
        app.mount("/viewer", StaticFiles(directory=VIEWER_STATIC), name="viewer")
    app.include_router(participants.router)
    app.include_router(admin.router)

    # the state and answer requests of every trial skip FastAPI (see trials_api)
    trials = TrialEndpoints(app, cfg=cfg, db=db, secret=secret)
    guarded = Guard(trials, allowed_hosts=hosts, max_body=max_body)
    guarded.state = app.state
    return guarded


def _record_config(cfg: TestConfig, db: Database, url: str) -> None:
    """Store the test's settings in the database, warning when they changed under participants."""
    previous = db.get_meta("config")
    if previous and previous.get("digest") != cfg.digest and db.progress():
        import warnings

        warnings.warn(f"the configuration {cfg.path} changed since participants started this test "
                      f"(database {url}); their stored trial order is kept", stacklevel=3)
    db.set_meta("config", {"name": cfg.name, "type": cfg.type, "digest": cfg.digest,
                           "path": str(cfg.path), "hidden_reference": cfg.hidden_reference,
                           "anchor": cfg.anchor, "screening_threshold": cfg.screening_threshold,
                           "screening_fraction": cfg.screening_fraction,
                           "scale_points": cfg.scale_points,
                           "demographics": [q.name for q in cfg.demographics]})


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


__all__ = ["create_app", "app_from_env", "default_allowed_hosts", "split_host", "Guard", "CSP",
           "results_document", "results_csv"]
