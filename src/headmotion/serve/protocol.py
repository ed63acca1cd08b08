"""The WebSocket protocol of ``headmotion serve``: uvicorn's websockets (sans-I/O) protocol with two
additions the stream's documented behaviour needs.

* A message over the protocol's size limit (``ws_max_size``, 4 × ``Limits.max_message_bytes``)
  is refused by the WebSocket layer before the app sees it; here the client still gets the API's
  error message ``{"type": "error", "error": "too_large", ...}`` and a close 1009 whose reason
  starts with ``too_large`` (the app counts the stream as ``too_large``).
* The app may lower the size limit of one connection while it is not authenticated
  (``scope["extensions"]["headmotion.max_size"]``, a function of the new limit in bytes), so a
  stranger cannot make the server buffer megabytes before its key is checked.
"""

from __future__ import annotations

import json

from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol
from websockets.protocol import State
from websockets.server import ServerProtocol

TOO_LARGE = 1009


class _Connection(ServerProtocol):
    """websockets' server connection whose failure on an oversized message sends the API's error first."""

    def fail(self, code, reason: str = "") -> None:
        if int(code) == TOO_LARGE and self.state is State.OPEN:
            detail = f"{reason or 'message too large'}; send audio in smaller messages"
            try:
                self.send_text(json.dumps({"type": "error", "error": "too_large", "detail": detail}).encode())
            except Exception:  # noqa: BLE001 - the connection cannot take it: the close still goes out
                pass
            reason = f"too_large: {detail}"[:120]
        super().fail(code, reason)


class StreamProtocol(WebSocketsSansIOProtocol):
    """uvicorn's ``websockets-sansio`` protocol with :class:`_Connection` and the per-connection
    size limit hook (module docstring)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.conn.__class__ = _Connection  # same state; only ``fail`` differs

    def handle_connect(self, event) -> None:
        super().handle_connect(event)
        scope = getattr(self, "scope", None)
        if isinstance(scope, dict):
            scope.setdefault("extensions", {})["headmotion.max_size"] = self._set_max_size

    def _set_max_size(self, limit: int | None) -> None:
        self.conn.max_message_size = self.config.ws_max_size if limit is None else int(limit)


#: what ``uvicorn --ws`` is given
WS_PROTOCOL = f"{__name__}:StreamProtocol"

__all__ = ["StreamProtocol", "WS_PROTOCOL"]
