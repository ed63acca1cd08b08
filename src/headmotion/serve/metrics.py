"""Operations of ``headmotion serve``: Prometheus metrics (``prometheus-client``) and one
structured log line (JSON) per request and per stream.

Metrics: ``headmotion_requests_total{route,status}``, ``headmotion_active_streams``,
``headmotion_frame_latency_seconds`` (from the arrival of the audio chunk that makes frames final
to their hand-over to the socket: the server's own share of a frame's latency, the model's
lookahead excluded), ``headmotion_stream_frames_total``, ``headmotion_errors_total{kind}``,
``headmotion_offline_seconds`` (synthesis time of an offline request).  With several workers
(``--workers N``) the counters live in prometheus-client's multiprocess directory
(``PROMETHEUS_MULTIPROC_DIR``, set by the command) and ``/metrics`` adds up every worker.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time

log = logging.getLogger("headmotion.serve")


class Metrics:
    """The server's metrics, in their own registry (several apps in one process do not clash)."""

    def __init__(self):
        from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram

        self.multiprocess = bool(os.environ.get("PROMETHEUS_MULTIPROC_DIR"))
        reg = None if self.multiprocess else CollectorRegistry()
        kw = {"registry": reg} if reg is not None else {}
        self.registry = reg
        if reg is not None:  # the process's CPU and memory (process_cpu_seconds_total, ...), as the default registry has
            from prometheus_client import ProcessCollector

            ProcessCollector(registry=reg)
        self.requests = Counter("headmotion_requests", "HTTP requests and stream openings by route and status",
                                ["route", "status"], **kw)
        gauge_kw = {"multiprocess_mode": "livesum"} if self.multiprocess else {}
        self.active_streams = Gauge("headmotion_active_streams", "Open motion streams", **kw, **gauge_kw)
        self.frame_latency = Histogram(
            "headmotion_frame_latency_seconds", "Audio chunk arrival to frames handed to the socket",
            buckets=(0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0), **kw)
        self.frames = Counter("headmotion_stream_frames", "Frames sent on streams", **kw)
        self.errors = Counter("headmotion_errors", "Errors by kind", ["kind"], **kw)
        self.offline_seconds = Histogram("headmotion_offline_seconds", "Synthesis time of offline requests",
                                         buckets=(0.05, 0.1, 0.25, 0.5, 1, 2, 5, 10, 30, 60), **kw)

    def render(self) -> tuple[bytes, str]:
        """The exposition text and its content type."""
        from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, generate_latest

        if self.multiprocess:
            from prometheus_client import multiprocess

            reg = CollectorRegistry()
            multiprocess.MultiProcessCollector(reg)
            return generate_latest(reg), CONTENT_TYPE_LATEST
        return generate_latest(self.registry), CONTENT_TYPE_LATEST


def setup_logging(level: str = "info") -> None:
    """One JSON object per line on stderr for the ``headmotion.serve`` logger."""
    if any(getattr(h, "_headmotion_json", False) for h in log.handlers):
        return
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(message)s"))
    handler._headmotion_json = True
    log.addHandler(handler)
    log.setLevel(level.upper())
    log.propagate = False


def log_event(event: str, **fields) -> None:
    """One structured line: ``{"ts", "event", ...fields}`` (never a key: callers pass its name)."""
    if log.isEnabledFor(logging.INFO):
        rec = {"ts": round(time.time(), 3), "event": event, **fields}
        log.info(json.dumps(rec, default=str, separators=(",", ":")))


__all__ = ["Metrics", "log_event", "setup_logging"]
