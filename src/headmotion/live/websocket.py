"""Live frames to any number of WebSocket clients (the seeds are silent).

:class:`WebSocketBroadcaster` listens on ``HOST:PORT`` and sends every frame record
(:func:`headmotion.live.frames.frame_records`, the JSON of one ``headmotion stream`` line) as one
text message to each connected client.  It runs an asyncio event loop in a background thread, so
the synthesis loop only calls :meth:`send`, which never blocks: each client has its own bounded
queue (``max_queue`` messages); a client too slow to keep up loses its oldest messages (counted
in ``dropped``) instead of delaying the others, and a client that disconnects is simply removed.
A port already in use raises :class:`~headmotion.errors.NetworkError` at :meth:`start`.

Library: ``websockets`` (the asyncio reference implementation, also what uvicorn uses for its
WebSocket support) rather than starlette/uvicorn: a frame broadcaster needs no HTTP routes, and
the ``websockets`` server starts and stops in a few ms, which keeps the tests short.  The live
browser page (:mod:`headmotion.web.live`) sits on the viewer's FastAPI app instead, because it
also serves the page.
"""

from __future__ import annotations

import asyncio
import json
import threading

from ..errors import NetworkError


class WebSocketBroadcaster:
    """Serves JSON frames to every connected WebSocket client.

    Parameters
    ----------
    host, port : where to listen (port 0: any free port; :attr:`port` tells which)
    max_queue : messages buffered per client before its oldest are dropped
    """

    name = "WebSocket"

    def __init__(self, host: str = "127.0.0.1", port: int = 8766, *, max_queue: int = 500):
        self.host, self.port = host, int(port)
        self.max_queue = max(1, int(max_queue))
        self.dropped = 0
        self.connections = 0          # clients that ever connected
        self._clients: set[asyncio.Queue] = set()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._stop: asyncio.Event | None = None

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self, timeout: float = 5.0) -> WebSocketBroadcaster:
        self._thread = threading.Thread(target=self._run, name="headmotion-websocket", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise NetworkError(f"--websocket {self.host}:{self.port}: the server did not start within {timeout} s")
        if self._error is not None:
            err = self._error
            if isinstance(err, OSError):
                raise NetworkError(f"--websocket {self.host}:{self.port}: cannot listen ({err.strerror or err}); "
                                   "is another program using the port? Pick another with --websocket HOST:PORT") from None
            raise NetworkError(f"--websocket {self.host}:{self.port}: cannot listen ({err})") from None
        return self

    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as exc:  # reported by start()
            self._error = exc
            self._ready.set()
        finally:
            loop.close()

    async def _main(self) -> None:
        from websockets.asyncio.server import serve

        self._stop = asyncio.Event()
        async with serve(self._handler, self.host, self.port, max_size=2 ** 16) as server:
            self.port = server.sockets[0].getsockname()[1] if self.port == 0 else self.port
            self._ready.set()
            await self._stop.wait()
            for q in list(self._clients):
                self._put(q, None)
            server.close()
            await asyncio.wait_for(server.wait_closed(), 2.0)

    async def _handler(self, ws) -> None:
        from websockets.exceptions import ConnectionClosed

        q: asyncio.Queue = asyncio.Queue()
        self._clients.add(q)
        self.connections += 1
        try:
            while True:
                msg = await q.get()
                if msg is None:
                    break
                await ws.send(msg)
        except ConnectionClosed:
            pass
        finally:
            self._clients.discard(q)

    def _put(self, q: asyncio.Queue, msg) -> None:
        if msg is not None and q.qsize() >= self.max_queue:
            q.get_nowait()
            self.dropped += 1
        q.put_nowait(msg)

    def _fanout(self, msgs: list[str]) -> None:
        for q in list(self._clients):
            for m in msgs:
                self._put(q, m)

    # -- the output interface ----------------------------------------------------------------
    @property
    def n_clients(self) -> int:
        return len(self._clients)

    def send(self, records: list[dict]) -> None:
        if not records or self._loop is None or self._loop.is_closed():
            return
        msgs = [json.dumps(r) for r in records]
        try:
            self._loop.call_soon_threadsafe(self._fanout, msgs)
        except RuntimeError:  # loop closing
            pass

    def close(self, timeout: float = 3.0) -> None:
        if self._loop is not None and self._stop is not None and not self._loop.is_closed():
            try:
                self._loop.call_soon_threadsafe(self._stop.set)
            except RuntimeError:
                pass
        if self._thread is not None:
            self._thread.join(timeout)

    def __enter__(self):
        return self.start() if self._thread is None else self

    def __exit__(self, *exc):
        self.close()


__all__ = ["WebSocketBroadcaster"]
