"""The Python client (:mod:`headmotion.serve.client`) against a real server on a loopback port:
offline calls give the library's motion, the async stream iterator gives the library's stream, and
refusals arrive as :class:`ServerError` with the server's kind."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest
from serve_helpers import SPEECH, registry, speech_f32

from headmotion.errors import ParameterError
from headmotion.io import load_audio
from headmotion.serve.client import Client, ServerError
from headmotion.serve.protocol import WS_PROTOCOL
from headmotion.synthesis import synthesize
from headmotion.types import Audio


@pytest.fixture(scope="module")
def url(tmp_path_factory):
    from headmotion.serve.app import create_app
    from headmotion.serve.auth import key_line
    from headmotion.serve.config import ServeConfig
    from headmotion.web.server import running_app

    kf = tmp_path_factory.mktemp("keys") / "keys.txt"
    kf.write_text(key_line("client-key", name="c") + "\n")
    app = create_app(ServeConfig(api_keys=str(kf)), registry=registry())
    with running_app(app, ws=WS_PROTOCOL) as u:
        yield u.rstrip("/")


def test_offline_calls(url):
    c = Client(url, api_key="client-key")
    assert [m["name"] for m in c.models()] == ["stream"]
    m = c.motion_json(SPEECH, model="stream", seed=4, gain=(1, 0.5, 1))
    want = synthesize(load_audio(SPEECH), registry().models["stream"], seed=4, gain=(1, 0.5, 1))[0]
    np.testing.assert_allclose(m.rotvec, want.rotvec, atol=1e-9)
    assert c.motion(SPEECH, model="stream", format="bvh").startswith(b"HIERARCHY")
    with pytest.raises(ServerError) as e:
        Client(url, api_key="wrong").motion(SPEECH, model="stream")
    assert e.value.kind == "unauthorized" and e.value.status == 401
    with pytest.raises(ServerError) as e:
        Client(url, api_key="client-key").motion(SPEECH, model="nope")
    assert e.value.kind == "unknown_model"


@pytest.mark.parametrize("frames", ["binary", "json"])
def test_stream_iterator(url, frames):
    x = speech_f32()

    async def run():
        c = Client(url, api_key="client-key")
        got = []
        async for f in c.stream((x[i:i + 320] for i in range(0, len(x), 320)), sample_rate=16000, seed=1,
                                frames=frames):
            got.append(f)
        return got

    got = asyncio.run(run())
    assert [f.first for f in got] == list(np.cumsum([0] + [len(f.rotvec) for f in got[:-1]]))
    rv = np.vstack([f.rotvec for f in got])
    s = registry().models["stream"].stream(seed=1)
    want = np.vstack([s.push(x).rotvec, s.flush().rotvec])
    np.testing.assert_allclose(rv, want, atol=1e-6)


def test_stream_refusal(url):
    async def run():
        async for _ in Client(url, api_key="client-key").stream([np.zeros(160, np.float32)], model="nope"):
            pass

    with pytest.raises(ServerError) as e:
        asyncio.run(run())
    assert e.value.kind == "unknown_model"


def test_stereo_chunks_are_mixed_down_not_interleaved(url):
    """A stereo file read with soundfile is (samples, 2): the client streams the mean of the two
    channels — the frames of the mono mix, as many as the file has samples, not twice as many."""
    from headmotion.serve.client import mono

    x = speech_f32()
    stereo = np.stack([x, 0.5 * x], axis=1)  # (samples, 2)
    np.testing.assert_allclose(mono(stereo), 0.75 * x, rtol=1e-6)

    async def run(chunks):
        out = []
        async for f in Client(url, api_key="client-key").stream(chunks, sample_rate=16000, seed=1):
            out.append(f)
        return np.vstack([f.rotvec for f in out])

    got = asyncio.run(run(stereo[i:i + 320] for i in range(0, len(x), 320)))
    s = registry().models["stream"].stream(seed=1)
    want = np.vstack([s.push(0.75 * x).rotvec, s.flush().rotvec])
    assert got.shape == want.shape  # 69 frames for 2.78 s at 25 fps, not 139
    np.testing.assert_allclose(got, want, atol=1e-6)
    for bad in (np.zeros((2, 160), np.float32), np.zeros((4, 4, 4), np.float32)):
        with pytest.raises(ParameterError, match="samples, channels"):
            mono(bad)
    with pytest.raises(ParameterError, match="channels-first"):
        asyncio.run(run([np.zeros((2, 320), np.float32)]))


class _RestartsOnce:
    """ASGI wrapper: the first stream is closed with 1012 (server restart) after ``after`` messages."""

    def __init__(self, app, after):
        self.app, self.after, self.streams = app, after, 0
        self.state = app.state

    async def __call__(self, scope, receive, send):
        if scope["type"] != "websocket":
            return await self.app(scope, receive, send)
        self.streams += 1
        if self.streams > 1:
            return await self.app(scope, receive, send)
        seen = [0]

        async def receive_then_restart():
            msg = await receive()
            if msg["type"] == "websocket.receive":
                seen[0] += 1
                if seen[0] > self.after:
                    await send({"type": "websocket.close", "code": 1012, "reason": "service restart"})
                    return {"type": "websocket.disconnect", "code": 1012}
            return msg

        await self.app(scope, receive_then_restart, send)


def test_stream_reconnects_after_a_restart():
    """Closed with 1012 mid-stream (the client sends faster than real time, so most of the audio is
    in flight), the client opens a new stream and sends again what the server had not confirmed;
    frame numbers go on in the whole stream, and the last frame is the audio's."""
    from headmotion.serve.app import create_app
    from headmotion.serve.config import ServeConfig
    from headmotion.web.server import running_app

    x = speech_f32()
    app = _RestartsOnce(create_app(ServeConfig(), registry=registry()), after=100)
    with running_app(app, ws=WS_PROTOCOL) as u:
        async def run():
            out = []
            async for f in Client(u.rstrip("/")).stream((x[i:i + 160] for i in range(0, len(x), 160)),
                                                         sample_rate=16000):
                out.append(f)
            return out

        got = asyncio.run(run())
    assert app.streams == 2
    firsts = [f.first for f in got]
    ends = [f.first + len(f.rotvec) for f in got]
    assert all(b >= a for a, b in zip(ends, firsts[1:]))  # in order, none twice
    gaps = [b - a for a, b in zip(ends, firsts[1:]) if b != a]
    assert len(gaps) <= 1 and all(g <= 20 for g in gaps)  # at most the lookahead and a chunk missing
    n = len(registry().models["stream"].predict(Audio(x, 16000)))
    assert ends[-1] == n  # the last frame is the audio's (2.78 s at 25 fps): the rest was sent again
    assert sum(len(f.rotvec) for f in got) >= n - 20
