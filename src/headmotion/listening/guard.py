"""The listening-test server's guard: one ASGI middleware in front of every request (Host
allow-list, security headers, body-size limit, same-origin writes; what each rule does and why is
in :mod:`headmotion.listening.app`), and the host-name helpers it uses."""

from __future__ import annotations

import json
import socket

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


def is_loopback(addr: str) -> bool:
    """Whether ``addr`` is a loopback IP address (False for anything that is not an address)."""
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
    (see :mod:`headmotion.listening.app`)."""

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


__all__ = ["CSP", "SECURITY_HEADERS", "MAX_BODY", "SESSION_COOKIE", "CSRF_COOKIE", "Guard",
           "split_host", "default_allowed_hosts", "is_loopback"]
