"""The live page's server (``headmotion view --live``) without a browser: two WebSocket clients
stream PCM at once, one leaves in the middle, the other keeps getting every frame; a bad
handshake gets a clear error message.  Bounded in time."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import OLD_DNN_MODEL

pytestmark = pytest.mark.timeout(120)
#: a model that streams with lookahead at 100 fps (the former shipped default, mfcc-dnn)
MODEL = OLD_DNN_MODEL


def _pcm(seconds: float, sr: int) -> np.ndarray:
    t = np.arange(int(seconds * sr)) / sr
    f0 = 120 + 30 * np.sin(2 * np.pi * 0.7 * t)
    ph = 2 * np.pi * np.cumsum(f0) / sr
    env = 0.5 + 0.5 * np.sin(2 * np.pi * 3 * t) ** 2
    return (0.2 * env * sum(np.sin(k * ph) / k for k in range(1, 6))).astype("<f4")


def _frames(msgs):
    return [f for m in msgs for f in m.get("frames", [])]


def test_two_clients_one_leaves_the_other_gets_every_frame():
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from headmotion.systems.base import load_model
    from headmotion.web.live import running_live_server

    sr = 48000
    x = _pcm(3.0, sr)
    chunk = sr // 100
    with running_live_server(load_model(MODEL)) as url:
        ws_url = url.replace("http", "ws") + "ws"
        with connect(ws_url, open_timeout=5) as a, connect(ws_url, open_timeout=5) as b:
            for c in (a, b):
                c.send(json.dumps({"sample_rate": sr}))
                assert json.loads(c.recv(timeout=10))["ready"] is True
            got_a = []
            for i in range(0, len(x), chunk):
                a.send(x[i:i + chunk].tobytes())
                if b is not None:
                    if i >= len(x) // 3:
                        b.close()            # leaves without saying goodbye
                        b = None
                    else:
                        b.send(x[i:i + chunk].tobytes())
            a.send(json.dumps({"end": True}))
            while True:
                try:
                    got_a.append(json.loads(a.recv(timeout=10)))
                except (TimeoutError, ConnectionClosed):  # the server closes after the flush
                    break
    frames = _frames(got_a)
    assert [f["frame"] for f in frames] == list(range(len(frames)))
    assert abs(len(frames) - 300) <= 1           # 3 s at 100 fps, the last ones from the flush
    rv = np.array([f["rotvec"] for f in frames])
    assert np.all(np.isfinite(rv)) and np.degrees(np.ptp(rv, axis=0)).max() > 0.5


def test_bad_handshake_is_a_clear_error():
    from websockets.sync.client import connect

    from headmotion.systems.base import load_model
    from headmotion.web.live import running_live_server

    with running_live_server(load_model(MODEL)) as url, \
            connect(url.replace("http", "ws") + "ws", open_timeout=5) as c:
        c.send(json.dumps({"sample_rate": 3}))
        msg = json.loads(c.recv(timeout=10))
    assert "sample_rate must be 8000-192000 Hz; got 3" in msg["error"]
