"""Access checks shared by the routes: who is asking (:mod:`headmotion.serve.auth`) and whether
their key's request rate allows one more request; the API's one error type."""

from __future__ import annotations

import re

from ..errors import HeadMotionError
from .auth import Key


class ApiError(HeadMotionError):
    """An answer other than success: HTTP ``status``, a machine-readable ``kind`` and a sentence."""

    def __init__(self, status: int, kind: str, detail: str, headers: dict | None = None):
        super().__init__(detail)
        self.status, self.kind, self.detail, self.headers = status, kind, detail, headers or {}


def api_wording(text: str) -> str:
    """A library message in the API's words: the command line's ``(--gain)`` asides dropped and its
    options named as the query parameters they are (``--gain-pitch`` → ``gain_pitch``)."""
    text = re.sub(r" \(--[a-z][a-z-]*\)", "", text)
    return re.sub(r"(?<![\w-])--([a-z][a-z-]*)", lambda m: m.group(1).replace("-", "_"), text)


def identify(st, authorization: str | None) -> Key:
    """The caller's key, or 401."""
    key = st.keys.identify(authorization)
    if key is None:
        why = "no API key" if not authorization else "unknown API key or not 'Bearer KEY'"
        raise ApiError(401, "unauthorized", f"{why}: send the header 'Authorization: Bearer KEY'",
                       {"www-authenticate": 'Bearer realm="headmotion"'})
    return key


def check_rate(st, key: Key) -> None:
    """429 when the key has used its requests per minute."""
    if not st.limiter.allow(key):
        raise ApiError(429, "rate_limited", f"key {key.name!r} is over its limit of {key.rate} requests per minute",
                       {"retry-after": str(max(1, round(60 / key.rate)))})


def authorize(request, st) -> Key:
    """Identify the caller of an HTTP request and count the request against its rate."""
    key = identify(st, request.headers.get("authorization"))
    check_rate(st, key)
    request.state.key = key.name
    return key


__all__ = ["ApiError", "api_wording", "authorize", "check_rate", "identify"]
