"""Running ``headmotion serve``: the checks made before any process starts (where it may listen,
the key file, the models), then uvicorn with one or several worker processes.

Each worker builds the same app from the settings in ``HEADMOTION_SERVE_CONFIG``
(:func:`headmotion.serve.app.app_from_env`) and loads the models once.  With several workers,
uvicorn's supervisor restarts a worker that dies; Prometheus counters are shared through
prometheus-client's multiprocess directory.  SIGINT / SIGTERM: uvicorn stops accepting, lets
offline requests finish (up to ``GRACE_S``) and closes open streams with code 1012 (service
restart), so clients know to reconnect.
"""

from __future__ import annotations

import os
import shutil
import socket
import tempfile
from pathlib import Path

from ..errors import ParameterError
from .config import ENV, ServeConfig, check_bind
from .protocol import WS_PROTOCOL

GRACE_S = 10


def preflight(config: ServeConfig) -> dict:
    """Check everything a worker would trip on; returns the model files."""
    from . import engine
    from .auth import load_keys

    check_bind(config.host, config.api_keys)
    if config.api_keys is not None:
        load_keys(config.api_keys)
    files = engine.model_files(None if config.models_dir is None else Path(config.models_dir))
    engine.check_loaded(files)
    return files


def check_port(host: str, port: int) -> None:
    """Refuse a port another program listens on, before anything is announced (uvicorn binds it
    with the same options a moment later)."""
    if not port:
        return
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    try:
        with socket.socket(family, socket.SOCK_STREAM) as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((host.strip("[]"), int(port)))
    except OSError as exc:
        raise ParameterError(f"cannot listen on {host}:{port}: {exc.strerror or exc} (is another program "
                             f"using the port? choose another with --port)") from None


def run(config: ServeConfig, *, workers: int = 1, announce=print) -> None:
    """Serve until interrupted."""
    import uvicorn

    files = preflight(config)
    check_port(config.host, config.port)  # before the banner: a port in use is one clear error
    os.environ[ENV] = config.to_json()
    metrics_dir = None
    if workers > 1 and not os.environ.get("PROMETHEUS_MULTIPROC_DIR"):
        metrics_dir = tempfile.mkdtemp(prefix="headmotion-metrics-")
        os.environ["PROMETHEUS_MULTIPROC_DIR"] = metrics_dir
    host = f"[{config.host}]" if ":" in config.host else config.host
    announce(f"headmotion serve: http://{host}:{config.port}/ (API /docs, example /v1/example), "
             f"{workers} worker{'s' if workers > 1 else ''}, models {sorted(files)}, "
             f"{'API keys required' if config.api_keys else 'no keys: localhost only'}")
    try:
        uvicorn.run("headmotion.serve.app:app_from_env", factory=True, host=config.host, port=config.port,
                    workers=workers, ws=WS_PROTOCOL,
                    ws_max_size=4 * config.limits.max_message_bytes, access_log=False,
                    log_level="warning", timeout_graceful_shutdown=GRACE_S, server_header=False)
    finally:
        if metrics_dir is not None:
            shutil.rmtree(metrics_dir, ignore_errors=True)


__all__ = ["preflight", "check_port", "run", "GRACE_S"]
