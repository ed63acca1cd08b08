"""``headmotion view --live``: the bundled viewer driven by the microphone or an audio file through
a WebSocket (the seeds are silent on live use).

The page (``static/live.html``) captures audio in the browser — ``getUserMedia`` for the
microphone, or a chosen file decoded and played — and sends it as binary messages of float32
mono PCM to ``/ws`` (after one text message ``{"sample_rate": sr}``).  The server resamples it on
the stream to the model's rate and pushes it into a fresh
:func:`headmotion.synthesis.open_stream` per connection (``sample_rate`` the page's), and sends back each batch of final frames as one text
message ``{"frames": [record, ...]}`` (the JSON-line records of ``headmotion stream``).  The page
moves the head to the newest frame and shows the latency: for a frame at audio time τ, the
browser's wall time on receipt minus the wall time at which the sample at τ was captured (known
from the send time and position of the chunk holding it), median and 95th percentile of the
last 200 frames.

Libraries: the viewer's FastAPI app and uvicorn (the ``websockets`` package provides uvicorn's
WebSocket protocol); the page uses an AudioWorklet (no ScriptProcessorNode, which is deprecated).
"""

from __future__ import annotations

import contextlib
import json
import time
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from .server import STATIC


def create_live_app(model, *, seed: int | None = None, model_path: str | None = None):
    """FastAPI app serving the live page and its WebSocket for a loaded causal model."""
    from fastapi import FastAPI, WebSocketDisconnect
    from fastapi.responses import FileResponse
    from fastapi.staticfiles import StaticFiles

    from ..live.frames import frame_records
    from ..synthesis import open_stream

    if not model.can_stream:
        raise ParameterError(f"view --live needs a model that streams (tws-basic, tws-hier, le2012, the DNN "
                             f"systems); "
                             f"{model_path or 'the model'} is {getattr(model, 'name', '?')!r}")
    model_sr = int(model.sample_rate)
    app = FastAPI(title="headmotion live", docs_url=None, redoc_url=None, openapi_url=None)

    @app.get("/")
    def index():
        return FileResponse(STATIC / "live.html", media_type="text/html")

    @app.get("/api/live")
    def info():
        st = open_stream(model, seed=seed)
        return {"system": model.name, "sample_rate": model_sr, "latency_ms": float(getattr(st, "latency_ms", 0.0)),
                "model": model_path}

    async def ws(websocket):  # a plain Starlette route (no annotation for FastAPI to resolve)
        await websocket.accept()
        try:
            hello = json.loads(await websocket.receive_text())
            sr = int(hello.get("sample_rate", 0))
            if not 8000 <= sr <= 192000:
                await websocket.send_text(json.dumps({"error": f"sample_rate must be 8000-192000 Hz; got {sr}"}))
                await websocket.close()
                return
            stream = open_stream(model, seed=seed, sample_rate=sr)
            frame = 0
            await websocket.send_text(json.dumps({"ready": True, "latency_ms": float(getattr(stream, "latency_ms", 0.0))}))
            while True:
                msg = await websocket.receive()
                if msg.get("type") == "websocket.disconnect":
                    break
                data = msg.get("bytes")
                if data is None:
                    if not (msg.get("text") and json.loads(msg["text"]).get("end")):
                        continue
                    motion = stream.flush()  # end of the audio: what the resampler and the model still hold
                else:
                    motion = stream.push(np.frombuffer(data[: len(data) // 4 * 4], dtype="<f4"))
                rv, fps = motion.rotvec, float(motion.fps)
                if len(rv):
                    recs = frame_records(rv, fps, frame)
                    frame += len(recs)
                    await websocket.send_text(json.dumps({"frames": recs, "server_time": time.time()}))
                if data is None:
                    break
        except WebSocketDisconnect:
            pass

    from starlette.routing import WebSocketRoute

    app.router.routes.append(WebSocketRoute("/ws", ws))
    app.mount("/viewer", StaticFiles(directory=STATIC), name="viewer")
    return app


@contextlib.contextmanager
def running_live_server(model, *, host: str = "127.0.0.1", port: int = 0, seed: int | None = None,
                        model_path: str | None = None):
    """Run the live server in a background thread; yields its base URL."""
    from .server import running_app

    app = create_live_app(model, seed=seed, model_path=model_path)
    with running_app(app, host=host, port=port, ws="websockets-sansio") as url:
        yield url


def serve_live(model, *, host: str = "127.0.0.1", port: int = 8765, seed: int | None = None, model_path=None,
               open_browser: bool = True, announce=print):
    """Serve the live page until interrupted (``headmotion view --live``)."""
    from .server import wait_until_interrupted

    with running_live_server(model, host=host, port=port, seed=seed,
                             model_path=None if model_path is None else str(Path(model_path))) as url:
        wait_until_interrupted(url, open_browser=open_browser, announce=announce)


__all__ = ["create_live_app", "running_live_server", "serve_live"]
