"""Shared pieces of the ``headmotion serve`` tests: the shipped streaming model loaded once, apps
with chosen limits and keys, and a reader of a stream's messages."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPEECH = ROOT / "examples" / "speech" / "short.wav"
_REG = {}


def registry(*names):
    """A loaded registry of shipped models (cached per set of names)."""
    from headmotion.serve import engine
    from headmotion.serve.models import Registry

    names = names or ("stream",)
    if names not in _REG:
        _REG[names] = Registry({n: engine.SHIPPED[n] for n in names}).load_all()
    return _REG[names]


def client(tmp_path=None, *, keys=None, names=("stream",), origins=(), **limits):
    """A TestClient of an app on localhost; ``keys``: [(key, name, streams, rate)] written hashed;
    ``origins``: the allowed web page origins."""
    from headmotion.serve.app import create_app
    from headmotion.serve.auth import key_line
    from headmotion.serve.config import Limits, ServeConfig

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from fastapi.testclient import TestClient
    key_file = None
    if keys:
        key_file = Path(tmp_path) / "keys.txt"
        key_file.write_text("".join(key_line(k, name=n, streams=s, rate=r) + "\n" for k, n, s, r in keys))
    cfg = ServeConfig(api_keys=None if key_file is None else str(key_file), allowed_origins=tuple(origins),
                      limits=Limits(**limits))
    return TestClient(create_app(cfg, registry=registry(*names)), base_url="http://localhost")


WS = "ws://localhost/v1/stream"


def start(**fields) -> str:
    return json.dumps({"type": "start", **fields})


def read_until_close(ws) -> list[dict]:
    """Every message until the server closes: ``{"type": "websocket.send"/"websocket.close", ...}``."""
    out = []
    while True:
        m = ws.receive()
        out.append(m)
        if m["type"] == "websocket.close":
            return out


def speech_f32():
    import soundfile as sf

    x, sr = sf.read(str(SPEECH), dtype="float32")
    assert sr == 16000
    return np.ascontiguousarray(x)
