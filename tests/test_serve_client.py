"""The Python client (:mod:`headmotion.serve.client`) against a real server on a loopback port:
offline calls give the library's motion, the async stream iterator gives the library's stream, and
refusals arrive as :class:`ServerError` with the server's kind."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest
from serve_helpers import SPEECH, registry, speech_f32

from headmotion.io import load_audio
from headmotion.serve.client import Client, ServerError
from headmotion.serve.protocol import WS_PROTOCOL


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
    want = registry().models["stream"].predict(load_audio(SPEECH), seed=4, gain=(1, 0.5, 1))
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
