"""The listening-test server's FastAPI routes, one router per job: the pages
(:mod:`.pages`), the participant API and stimuli (:mod:`.participants`) and the admin API
(:mod:`.admin`).  Every handler reads the test's :class:`ServerContext` from the app's state
(``app.state.ctx``, set by :func:`headmotion.listening.app.create_app`)."""

from __future__ import annotations

import hashlib
import hmac
from dataclasses import dataclass, field

from fastapi import Request, Response

from ..config import TestConfig
from ..db import Database
from ..guard import SESSION_COOKIE


@dataclass
class ServerContext:
    """What the routes of one test share: its configuration and database, the server's secret
    (blinded stimulus ids, address hashes), the admin token and the motion JSON cache."""

    cfg: TestConfig
    db: Database
    secret: bytes
    token: str
    motion_cache: dict[str, bytes] = field(default_factory=dict)
    #: the admin session cookie's value: a keyed hash of the admin token
    session_value: str = field(init=False)

    def __post_init__(self) -> None:
        self.session_value = hmac.new(self.secret, b"admin-session:" + self.token.encode(),
                                      hashlib.sha256).hexdigest()

    def set_session(self, resp: Response, secure: bool) -> None:
        """Set the admin session cookie (HttpOnly, SameSite=Strict) on ``resp``."""
        resp.set_cookie(SESSION_COOKIE, self.session_value, httponly=True, samesite="strict", secure=secure,
                        path="/")


def server_context(request: Request) -> ServerContext:
    """FastAPI dependency: the test's :class:`ServerContext`."""
    return request.app.state.ctx


__all__ = ["ServerContext", "server_context"]
