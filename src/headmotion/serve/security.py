"""Host and Origin allow-lists and security headers of ``headmotion serve``: one ASGI middleware
for HTTP and WebSocket alike.  The host parsing, the default allowed names and the headers are the
listening-test server's (:mod:`headmotion.listening.app`), imported, so both servers answer alike.

* ``Host`` not an allowed name → 400 (HTTP) or a refused handshake (WebSocket): no DNS rebinding.
* ``Origin`` (sent by browsers) must be this server or one of ``--allowed-origin``; a cross-site
  page cannot drive a stream or spend a key's quota from a visitor's browser.  Programs send no
  ``Origin`` and are not concerned.
* Every HTTP response carries the listening server's security headers (CSP, ``X-Frame-Options``,
  ``nosniff``, ``Referrer-Policy``, COOP) and ``Cache-Control: no-store``; the OpenAPI page
  (``/docs``) gets a CSP that lets it load Swagger UI from its CDN.
"""

from __future__ import annotations

import json

from ..listening.guard import SECURITY_HEADERS, default_allowed_hosts, split_host

DOCS_CSP = ("default-src 'self'; script-src 'self' 'unsafe-inline' https://cdn.jsdelivr.net; "
            "style-src 'self' 'unsafe-inline' https://cdn.jsdelivr.net; img-src 'self' data: "
            "https://fastapi.tiangolo.com; connect-src 'self'; object-src 'none'; base-uri 'none'; "
            "frame-ancestors 'none'")
_HEADERS = [*SECURITY_HEADERS, (b"cache-control", b"no-store")]
_DOCS_HEADERS = [(b"content-security-policy", DOCS_CSP.encode()),
                 *[h for h in _HEADERS if h[0] != b"content-security-policy"]]
_REPLACED = frozenset(name for name, _ in _HEADERS)


def allowed_hosts(host: str, extra=()) -> set[str]:
    """The listening server's default names for ``host`` plus ``extra`` (``--allowed-host``)."""
    return default_allowed_hosts(host) | {split_host(h) for h in extra}


def origin_ok(origin: str | None, host: str, allowed_origins: set[str]) -> bool:
    """A request's ``Origin`` is absent (not a browser), this server, or an allowed origin."""
    if origin is None:
        return True
    if origin == "null":
        return False
    o = origin.rstrip("/").lower()
    return o in allowed_origins or o.split("://", 1)[-1] == host.lower()


class Guard:
    """ASGI middleware: Host and Origin allow-lists, security headers (module docstring)."""

    def __init__(self, app, *, hosts: set[str], origins=()):
        self.app = app
        self.hosts = {h.lower() for h in hosts}
        self.origins = {o.rstrip("/").lower() for o in origins}

    async def __call__(self, scope, receive, send):
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        headers = dict(scope.get("headers") or [])
        host = headers.get(b"host", b"").decode("latin-1")
        origin = headers.get(b"origin")
        origin = None if origin is None else origin.decode("latin-1")
        refusal = None
        if split_host(host) not in self.hosts:
            refusal = (400, "host not allowed (start the server with --allowed-host NAME to serve this name)",
                       "bad_host")
        elif (kind == "websocket" or scope.get("method") not in ("GET", "HEAD", "OPTIONS")) and \
                not origin_ok(origin, host, self.origins):
            refusal = (403, "cross-origin request refused (start the server with --allowed-origin ORIGIN "
                            "to accept this page)", "bad_origin")
        if refusal is not None:
            if kind == "websocket":
                await receive()  # websocket.connect
                await send({"type": "websocket.close", "code": 1008, "reason": refusal[1][:120]})
                return
            return await plain(send, *refusal)
        if kind == "websocket":
            return await self.app(scope, receive, send)
        docs = scope.get("path", "") in ("/docs", "/docs/oauth2-redirect")

        async def send_with_headers(msg):
            if msg["type"] == "http.response.start":
                hs = [h for h in msg.get("headers", ()) if h[0].lower() not in _REPLACED]
                msg = {**msg, "headers": hs + (_DOCS_HEADERS if docs else _HEADERS)}
            await send(msg)

        await self.app(scope, receive, send_with_headers)


async def plain(send, status: int, text: str, kind: str | None = None, extra_headers=()) -> None:
    """A JSON error ``{"error": kind, "detail": text}`` with the security headers."""
    body = json.dumps({"error": kind or "refused", "detail": text}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode()), *_HEADERS, *extra_headers]})
    await send({"type": "http.response.body", "body": body})


__all__ = ["Guard", "allowed_hosts", "origin_ok", "plain", "DOCS_CSP"]
