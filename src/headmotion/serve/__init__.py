"""``headmotion serve``: head motion as a service — offline (``POST /v1/motion``) and streaming
(``WS /v1/stream``) over HTTP, with API keys, limits, metrics and a Python client
(:mod:`headmotion.serve.client`).  docs/serve.md describes the protocol.

Modules: :mod:`.app` (the app factory), :mod:`.offline`, :mod:`.stream` (routes and protocol),
:mod:`.auth` and :mod:`.access` (keys and per-key limits), :mod:`.security` (Host/Origin, headers),
:mod:`.metrics` (Prometheus, JSON log lines), :mod:`.models` (the models of a worker),
:mod:`.engine` (the one door into synthesis), :mod:`.config`, :mod:`.runner` (processes),
:mod:`.client`.  Nothing heavy is imported here.
"""

from __future__ import annotations


def __getattr__(name):
    if name in ("create_app", "app_from_env"):
        from . import app

        return getattr(app, name)
    if name in ("ServeConfig", "Limits"):
        from . import config

        return getattr(config, name)
    raise AttributeError(name)


__all__ = ["create_app", "app_from_env", "ServeConfig", "Limits"]
