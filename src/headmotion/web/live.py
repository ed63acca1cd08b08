"""``headmotion view --live``: the bundled viewer driven by the microphone or an audio file through
a WebSocket, with any model that streams (the shipped ``stream`` model by default).

The page (body ``static/live.body.html``) captures audio in the browser — ``getUserMedia`` for the
microphone, or a chosen file decoded and played — and streams it over ``WS /v1/stream``, the
service's protocol (docs/serve.md; :func:`headmotion.serve.local.mount_stream` answers it with the
very session ``headmotion serve`` runs): a start message ``{"type": "start", "sample_rate": sr,
"encoding": "f32le", "resample": "fast"}`` (and the server's ``seed``), binary messages of float32
mono PCM, ``{"type": "end"}`` at the end of a file.  The stream resamples to the model's rate and
pushes into one :func:`headmotion.synthesis.open_stream` per connection; the final frames come back
as ``{"type": "frames", "frames": [record, ...]}`` (the JSON-line records of ``headmotion
stream``).  The page moves the head to the newest frame and shows the latency: for a frame at
audio time τ, the browser's wall time on receipt minus the wall time at which the sample at τ was
captured (known from the send time and position of the chunk holding it), median and 95th
percentile of the last 200 frames.

The app also serves the avatar page, ``/v1/avatar`` (:func:`headmotion.serve.avatar.mount_avatar`),
which streams over the same route.

Libraries: the viewer's FastAPI app and uvicorn (the ``websockets`` package provides uvicorn's
WebSocket protocol); the page uses an AudioWorklet (no ScriptProcessorNode, which is deprecated).
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from ..errors import ParameterError
from .server import page_app


def create_live_app(model, *, seed: int | None = None, model_path: str | None = None):
    """FastAPI app serving the live page, the avatar page and ``/v1/stream`` for a loaded causal model."""
    from ..serve.avatar import mount_avatar
    from ..serve.local import mount_stream
    from ..synthesis import check_seed, open_stream

    if not model.can_stream:
        raise ParameterError(f"view --live needs a model that streams (the shipped 'stream' and 'default', "
                             f"motion-match, tws-basic, tws-hier, le2012, the DNN systems); "
                             f"{model_path or 'the model'} is {getattr(model, 'name', '?')!r}")
    check_seed(seed, allow_none=True)
    name, path = _model_name(model_path)
    model_sr = int(model.sample_rate)
    app = page_app("live", "live")

    @app.get("/api/live")
    def info():
        st = open_stream(model, seed=seed)
        return {"system": model.name, "sample_rate": model_sr, "latency_ms": float(getattr(st, "latency_ms", 0.0)),
                "model": model_path, "stream_model": name, "seed": seed}

    mount_stream(app, model, name=name, path=path)
    mount_avatar(app)
    return app


def _model_name(model_path: str | None) -> tuple[str, Path | None]:
    """The model's name on ``/v1/stream`` (a file's stem, a shipped name as it is) and its file."""
    if model_path is None:
        return "stream", None
    p = Path(model_path)
    if p.is_file():
        return p.stem, p
    from ..serve.engine import SHIPPED

    return str(model_path), SHIPPED.get(str(model_path))


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
