"""The live page's server (``headmotion view --live``) without a browser: it speaks ``/v1/stream``
(the service's protocol) with the one stream session; two clients stream PCM at once, one leaves in
the middle, the other keeps getting every frame — the frames of ``open_stream`` fed the same
chunks, bit for bit; a bad start message gets the service's error; the avatar page is served.
Bounded in time."""

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
    return [f for m in msgs if m.get("type") == "frames" for f in m["frames"]]


def _start(sr: int, **extra) -> str:
    return json.dumps({"type": "start", "sample_rate": sr, "encoding": "f32le", "resample": "fast", **extra})


def test_two_clients_one_leaves_the_other_gets_every_frame():
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from headmotion.systems.base import load_model
    from headmotion.web.live import running_live_server

    sr = 48000
    x = _pcm(3.0, sr)
    chunk = sr // 100
    with running_live_server(load_model(MODEL)) as url:
        ws_url = url.replace("http", "ws") + "v1/stream"
        with connect(ws_url, open_timeout=5) as a, connect(ws_url, open_timeout=5) as b:
            for c in (a, b):
                c.send(_start(sr))
                assert json.loads(c.recv(timeout=10))["type"] == "ready"
            got_a = []
            for i in range(0, len(x), chunk):
                a.send(x[i:i + chunk].tobytes())
                if b is not None:
                    if i >= len(x) // 3:
                        b.close()            # leaves without saying goodbye
                        b = None
                    else:
                        b.send(x[i:i + chunk].tobytes())
            a.send(json.dumps({"type": "end"}))
            while True:
                try:
                    got_a.append(json.loads(a.recv(timeout=10)))
                except (TimeoutError, ConnectionClosed):  # the server closes after the flush
                    break
    frames = _frames(got_a)
    assert got_a[-1] == {"type": "end", "frames": len(frames), "audio_seconds": 3.0}
    assert [f["frame"] for f in frames] == list(range(len(frames)))
    assert abs(len(frames) - 300) <= 1           # 3 s at 100 fps, the last ones from the flush
    rv = np.array([f["rotvec"] for f in frames])
    assert np.all(np.isfinite(rv)) and np.degrees(np.ptp(rv, axis=0)).max() > 0.5
    assert frames == _direct(load_model(MODEL), x, sr, chunk)  # the one stream session's frames


def _direct(model, x, sr, chunk, seed=None):
    """The records of :func:`open_stream` pushed the same chunks (what the page's former protocol sent)."""
    from headmotion.live.frames import frame_records
    from headmotion.synthesis import open_stream

    st = open_stream(model, seed=seed, sample_rate=sr)
    parts = [st.push(x[i:i + chunk]) for i in range(0, len(x), chunk)] + [st.flush()]
    rv = np.vstack([np.asarray(p.rotvec).reshape(-1, 3) for p in parts])
    return frame_records(rv, float(model.frame_rate), 0)


def test_the_servers_seed_and_the_avatar_page():
    """``view --live --seed N``: the page learns the seed from /api/live and starts its stream with
    it; the same app serves /v1/avatar and its files."""
    import urllib.request

    from websockets.sync.client import connect

    from headmotion.systems.base import load_model
    from headmotion.web.live import running_live_server

    model = load_model(MODEL)
    sr, x = 16000, _pcm(1.0, 16000)
    with running_live_server(model, seed=5) as url:
        info = json.loads(urllib.request.urlopen(url + "api/live", timeout=10).read())
        assert info["seed"] == 5 and info["sample_rate"] == int(model.sample_rate)
        page = urllib.request.urlopen(url + "v1/avatar", timeout=10).read().decode()
        assert "avatar-page.js" in page
        for f in ("v1/avatar/static/avatar.js", "v1/avatar/client/index.js", "v1/avatar/static/avatar.vrm"):
            assert urllib.request.urlopen(url + f, timeout=10).status == 200
        with connect(url.replace("http", "ws") + "v1/stream", open_timeout=5) as c:
            c.send(_start(sr, seed=info["seed"]))
            ready = json.loads(c.recv(timeout=10))
            c.send(x.tobytes())
            c.send(json.dumps({"type": "end"}))
            msgs = []
            while not msgs or msgs[-1]["type"] != "end":
                msgs.append(json.loads(c.recv(timeout=10)))
    assert ready["sample_rate"] == sr and ready["system"] == model.name
    assert _frames(msgs) == _direct(model, x, sr, len(x), seed=5)


def test_bad_start_is_a_clear_error():
    from websockets.sync.client import connect

    from headmotion.systems.base import load_model
    from headmotion.web.live import running_live_server

    with running_live_server(load_model(MODEL)) as url, \
            connect(url.replace("http", "ws") + "v1/stream", open_timeout=5) as c:
        c.send(_start(3))
        msg = json.loads(c.recv(timeout=10))
    assert msg == {"type": "error", "error": "bad_start",
                   "detail": "sample_rate must be a whole number of Hz between 8000 and 192000; got 3"}
