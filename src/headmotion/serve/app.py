"""The app factory of ``headmotion serve``: a FastAPI app with the offline route
(:mod:`.offline`), the stream route (:mod:`.stream`), the model list, health, readiness and
metrics, the OpenAPI page (``/docs``, ``/openapi.json``), the browser example (``/v1/example``) and
the avatar pages (``/v1/avatar``, :mod:`.avatar`; ``/v1/talkinghead``, :mod:`.talkinghead`),
behind the Host/Origin guard (:mod:`.security`) and one JSON log line per request.

The models are loaded once per worker, when it starts (the lifespan), and shared by every request
and stream; ``/readyz`` answers 503 until they are.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from dataclasses import dataclass
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import WebSocketRoute

from ..errors import HeadMotionError, ParameterError
from . import engine
from .access import ApiError, api_wording, identify
from .auth import KeyStore, RateLimiter, Slots, load_keys
from .config import ServeConfig
from .metrics import Metrics, log_event
from .models import Registry, UnknownModel
from .pages import WEB_STATIC
from .security import Guard, allowed_hosts, plain

#: the router's own HTTP answers → the error kind they carry
HTTP_KINDS = {404: "not_found", 405: "method_not_allowed"}
STATIC = Path(__file__).resolve().parent / "static"


@dataclass
class ServeState:
    """What every route of one worker shares."""

    config: ServeConfig
    registry: Registry
    keys: KeyStore
    limiter: RateLimiter
    slots: Slots
    metrics: Metrics
    started: float


class AccessLog:
    """ASGI middleware: one structured log line and one request count per HTTP request (streams
    log their own line when they end)."""

    def __init__(self, app, state_ref):
        self.app, self.state_ref = app, state_ref

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        t0, status = time.perf_counter(), [500]

        async def send_status(msg):
            if msg["type"] == "http.response.start":
                status[0] = msg["status"]
            await send(msg)

        try:
            await self.app(scope, receive, send_status)
        finally:
            st = self.state_ref()
            path = scope.get("path", "")
            route = path if path.startswith("/v1/") or path in ("/healthz", "/readyz", "/metrics") else "other"
            for page in ("/v1/example", "/v1/avatar", "/v1/talkinghead"):  # a page and its files: one route label
                if route.startswith(page):
                    route = page
            extra = (scope.get("state") or {})
            if st is not None:
                st.metrics.requests.labels(route, str(status[0])).inc()
            if path not in ("/healthz", "/readyz", "/metrics"):
                log_event("request", method=scope.get("method"), path=path, status=status[0],
                          ms=round((time.perf_counter() - t0) * 1000, 1), key=extra.get("key"),
                          **(extra.get("log") or {}))


def create_app(config: ServeConfig | None = None, *, registry: Registry | None = None):
    """The server's ASGI app.

    Parameters
    ----------
    config : ServeConfig, optional
        Host, key file, model folder, limits (default: localhost, no keys, the shipped models).
    registry : Registry, optional
        Models already loaded (tests share one); by default they are loaded at startup.

    Returns
    -------
    ASGI app (the Host/Origin guard around FastAPI).
    """
    config = config or ServeConfig()
    keys = (KeyStore(None) if config.api_keys is None else
            KeyStore(load_keys(config.api_keys), path=config.api_keys))  # read again when the file changes
    reg = registry or Registry(engine.model_files(None if config.models_dir is None else Path(config.models_dir)))
    st = ServeState(config, reg, keys, RateLimiter(), Slots(), Metrics(), time.time())
    app = FastAPI(title="headmotion serve", version=_version(), lifespan=_lifespan(st), redoc_url=None,
                  description="Natural head motion (pitch, yaw, roll) from speech: offline (POST /v1/motion) "
                              "and streaming (WebSocket `/v1/stream`, listed below under *stream*; its messages "
                              "in [/asyncapi.json](/asyncapi.json), AsyncAPI 3.0). Send `Authorization: Bearer "
                              "KEY` when the server has API keys. Errors are `{\"error\": KIND, \"detail\": "
                              "SENTENCE}`.")
    app.state.serve = st
    _add_error_handlers(app, st)
    _add_operations_routes(app, st)
    _add_api_routes(app, st)
    _mount(app, config)
    guarded = Guard(AccessLog(app, lambda: st), hosts=allowed_hosts(config.host, config.allowed_hosts),
                    origins=config.allowed_origins)
    guarded.state = app.state  # tests reach the shared state through the outer app
    return guarded


def _lifespan(st: ServeState):
    """The worker's lifespan: the port opens at once and the models load beside it (/readyz answers
    503 until they are); the shutdown is logged."""

    @contextlib.asynccontextmanager
    async def lifespan(_app):
        reg = st.registry
        loading = None if reg.ready else asyncio.create_task(asyncio.to_thread(_load, reg, st.keys))
        yield
        if loading is not None and not loading.done():
            loading.cancel()
        log_event("shutdown", open_streams=st.slots.total())

    return lifespan


def _add_error_handlers(app: FastAPI, st: ServeState) -> None:
    """Every error in the API's one shape, ``{"error": KIND, "detail": SENTENCE}``, in the API's words
    (query parameters, not the command line's options: :func:`.access.api_wording`), counted."""

    @app.exception_handler(ApiError)
    async def api_error(_request: Request, exc: ApiError):
        st.metrics.errors.labels(exc.kind).inc()
        return JSONResponse({"error": exc.kind, "detail": api_wording(exc.detail)}, status_code=exc.status,
                            headers=exc.headers)

    @app.exception_handler(HeadMotionError)
    async def library_error(_request: Request, exc: HeadMotionError):
        kind = ("unknown_model" if isinstance(exc, UnknownModel) else
                "bad_parameter" if isinstance(exc, ParameterError) else "bad_input")
        st.metrics.errors.labels(kind).inc()
        return JSONResponse({"error": kind, "detail": api_wording(str(exc))},
                            status_code=404 if kind == "unknown_model" else 400)

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException):
        # the router's own answers (no such route, method not allowed) in the API's one error shape
        kind = HTTP_KINDS.get(exc.status_code, "http_error")
        detail = {404: f"no route {request.url.path!r}; the API is described at /openapi.json",
                  405: f"{request.method} is not allowed on {request.url.path!r}"}.get(exc.status_code, str(exc.detail))
        st.metrics.errors.labels(kind).inc()
        return JSONResponse({"error": kind, "detail": detail}, status_code=exc.status_code, headers=exc.headers)

    @app.exception_handler(RequestValidationError)
    async def validation_error(_request: Request, exc: RequestValidationError):
        st.metrics.errors.labels("bad_parameter").inc()
        msgs = "; ".join(f"{'.'.join(str(p) for p in e.get('loc', ())[1:])}: {e.get('msg')}" for e in exc.errors())
        return JSONResponse({"error": "bad_parameter", "detail": msgs}, status_code=400)


def _add_operations_routes(app: FastAPI, st: ServeState) -> None:
    """``/healthz``, ``/readyz`` and ``/metrics``."""
    reg, keys = st.registry, st.keys

    @app.get("/healthz", tags=["operations"], summary="The process answers")
    def healthz():
        return {"status": "ok"}

    @app.get("/readyz", tags=["operations"], summary="The models are loaded (open streams: with a key)")
    def readyz(request: Request):
        if not reg.ready:
            return JSONResponse({"status": "failed" if reg.error else "loading", "error": reg.error}, status_code=503)
        out = {"status": "ready", "models": sorted(reg.models)}
        if keys.identify(request.headers.get("authorization")) is not None:  # the load is not for strangers
            out["open_streams"] = st.slots.total()
        return out

    @app.get("/metrics", tags=["operations"], summary="Prometheus metrics")
    def metrics(request: Request):
        if keys.required:  # a key, but not a request against its rate (scrapes are not calls)
            request.state.key = identify(st, request.headers.get("authorization")).name
        body, ctype = st.metrics.render()
        return Response(body, media_type=ctype)


def _add_api_routes(app: FastAPI, st: ServeState) -> None:
    """``/v1/models``, ``/asyncapi.json``, the stream route's HTTP answer and the browser example."""
    reg = st.registry

    @app.get("/v1/models", tags=["motion"], summary="The models this server offers, with their cards")
    def models(request: Request):
        request.state.key = identify(st, request.headers.get("authorization")).name  # not counted against the rate
        reg.check_ready()
        return {"models": [reg.cards[n] for n in sorted(reg.cards)],
                "default_offline": engine.DEFAULT_OFFLINE, "default_stream": engine.DEFAULT_STREAM}

    @app.get("/asyncapi.json", tags=["stream"], summary="The stream protocol (AsyncAPI 3.0)")
    def asyncapi():
        from .asyncapi import document

        return document(_version())

    @app.get("/v1/stream", tags=["stream"], status_code=426, summary="WebSocket: speech in, frames out",
             description="A WebSocket route: connect with `ws://HOST/v1/stream` (`wss://` behind TLS). The "
                         "messages are described in [/asyncapi.json](/asyncapi.json) and docs/serve.md. A plain "
                         "HTTP request here answers 426.",
             responses={426: {"description": "Not a WebSocket handshake"}})
    def stream_over_http():
        return JSONResponse({"error": "upgrade_required", "detail": "/v1/stream is a WebSocket: connect with "
                             "ws:// (or wss://); the protocol is described at /asyncapi.json"}, status_code=426,
                            headers={"upgrade": "websocket"})

    @app.get("/v1/example", include_in_schema=False)
    def example():
        return FileResponse(STATIC / "example.html", media_type="text/html")


def _mount(app: FastAPI, config: ServeConfig) -> None:
    """The avatar pages, the offline route, the WebSocket routes, the example's files and CORS."""
    from . import offline
    from .avatar import mount_avatar
    from .stream import no_such_stream, stream_endpoint
    from .talkinghead import mount_talkinghead

    mount_avatar(app)
    mount_talkinghead(app)
    app.include_router(offline.router)
    app.router.routes.append(WebSocketRoute("/v1/stream", stream_endpoint))
    app.router.routes.append(WebSocketRoute("/{path:path}", no_such_stream))  # after every real route
    app.mount("/v1/example/static", StaticFiles(directory=STATIC), name="example-static")
    app.mount("/v1/example/viewer", StaticFiles(directory=WEB_STATIC), name="example-viewer")
    if config.allowed_origins:  # a page on an allowed origin may call the HTTP API (CORS; preflight answered)
        app.add_middleware(CORSMiddleware, allow_origins=[o.rstrip("/").lower() for o in config.allowed_origins],
                           allow_methods=["GET", "POST"], allow_headers=["authorization", "content-type"],
                           expose_headers=["content-disposition", "retry-after", "x-headmotion-model"],
                           max_age=600)


def _load(reg: Registry, keys: KeyStore) -> None:
    try:
        reg.load_all()
    except Exception as exc:  # the worker stays up and says why in /readyz and the log
        reg.error = f"{type(exc).__name__}: {exc}"
        log_event("load_failed", error=reg.error)
        return
    log_event("ready", models=sorted(reg.models), load_s=round(reg.load_seconds, 2),
              keys="required" if keys.required else "none (localhost only)")


def _version() -> str:
    from .. import __version__

    return str(__version__)


def app_from_env():
    """The app of one worker process (``uvicorn --factory``): settings from ``HEADMOTION_SERVE_CONFIG``."""
    from .metrics import setup_logging

    config = ServeConfig.from_env()
    setup_logging(config.log_level)
    return create_app(config)


__all__ = ["create_app", "app_from_env", "ServeState", "plain"]
