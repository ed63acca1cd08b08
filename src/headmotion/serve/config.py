"""Settings of ``headmotion serve`` (one JSON-serialisable object, so that every worker process
builds the same app from it) and the rule for where the server may listen."""

from __future__ import annotations

import ipaddress
import json
import os
from dataclasses import asdict, dataclass, field

from ..errors import ParameterError

ENV = "HEADMOTION_SERVE_CONFIG"


@dataclass(frozen=True)
class Limits:
    """Request size and duration limits (per request / per stream; per-key limits are in the
    key file, :mod:`headmotion.serve.auth`)."""

    max_body_bytes: int = 64 * 1024 * 1024      # an offline request's audio file
    max_audio_seconds: float = 600.0             # offline: longest speech per request
    max_stream_seconds: float = 3600.0           # a stream's audio (the stream ends with a reason)
    max_message_bytes: int = 1024 * 1024         # one WebSocket message (~32 s of 16 kHz float32)
    idle_timeout_s: float = 30.0                 # a stream that sends nothing this long is closed
    start_timeout_s: float = 10.0                # time to send the first (start) message
    queue_messages: int = 200                    # unsent frame messages per stream; when full, no more audio
                                                 # is read from that client until one is sent
    send_timeout_s: float = 10.0                 # a full queue that sends nothing this long: too_slow
    max_streams: int = 64                        # open streams per worker, all keys together


@dataclass(frozen=True)
class ServeConfig:
    host: str = "127.0.0.1"
    port: int = 8000
    models_dir: str | None = None
    api_keys: str | None = None
    allowed_hosts: tuple[str, ...] = ()
    allowed_origins: tuple[str, ...] = ()
    limits: Limits = field(default_factory=Limits)
    log_level: str = "info"

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> "ServeConfig":
        d = json.loads(text)
        d["limits"] = Limits(**d.get("limits", {}))
        d["allowed_hosts"] = tuple(d.get("allowed_hosts", ()))
        d["allowed_origins"] = tuple(d.get("allowed_origins", ()))
        return cls(**d)

    @classmethod
    def from_env(cls) -> "ServeConfig":
        text = os.environ.get(ENV)
        return cls() if not text else cls.from_json(text)


def is_loopback_host(host: str) -> bool:
    """``localhost`` or a loopback address (127.0.0.0/8, ::1)."""
    h = host.strip().strip("[]").lower()
    if h == "localhost":
        return True
    try:
        return ipaddress.ip_address(h).is_loopback
    except ValueError:
        return False


def check_bind(host: str, api_keys) -> None:
    """Without API keys the server is a developer's and listens on localhost only: any other
    interface (0.0.0.0, a LAN address, a name) needs ``--api-keys``."""
    if api_keys is None and not is_loopback_host(host):
        raise ParameterError(f"--host {host} would open the server to other machines without authentication; "
                             f"give --api-keys FILE (lines from `headmotion serve hash-key`), or listen on "
                             f"127.0.0.1")


__all__ = ["Limits", "ServeConfig", "check_bind", "is_loopback_host", "ENV"]
