"""``WS /v1/stream`` on an app of one's own: the service's stream route (:mod:`.stream`, the
protocol of docs/serve.md) for one model already loaded, on any FastAPI app — ``headmotion view
--live``'s, or an agent's server beside :func:`.avatar.mount_avatar`.

The app answers the stream exactly as ``headmotion serve`` does (the same session, limits, errors
and frames), for one local user: no API keys, the worker's limits of :class:`.config.Limits`, and
the loaded model as the stream's default (a start message may name it or leave it out).
"""

from __future__ import annotations

import time
from pathlib import Path


def mount_stream(app, model, *, name: str = "stream", path: Path | None = None, config=None):
    """Answer ``/v1/stream`` on the FastAPI ``app`` with ``model`` (a loaded model that streams),
    known to start messages as ``name``; ``path`` its file (for its card), ``config`` a
    :class:`.config.ServeConfig` for the limits (default: the service's).  Returns the state the
    route shares (``app.state.serve``)."""
    from starlette.routing import WebSocketRoute

    from .app import ServeState
    from .auth import KeyStore, RateLimiter, Slots
    from .config import ServeConfig
    from .metrics import Metrics
    from .models import Registry
    from .stream import stream_endpoint

    st = ServeState(config or ServeConfig(), Registry.of_loaded(name, model, path), KeyStore(None), RateLimiter(),
                    Slots(), Metrics(), time.time())
    app.state.serve = st
    app.router.routes.append(WebSocketRoute("/v1/stream", stream_endpoint))
    return st


__all__ = ["mount_stream"]
