"""``WS /v1/stream`` against a real server (uvicorn on a loopback port) with clients that send
faster than real time, as a TTS engine or a file does: every frame arrives, identical to
``POST /v1/motion`` for the same samples, with one client and with eight at once; a client that
stops reading its frames is still closed (``too_slow``) and its slot freed; the docs' Python
client example gets every frame."""

from __future__ import annotations

import asyncio
import io
import json
import socket

import numpy as np
import pytest
import soundfile as sf
from serve_helpers import ROOT, registry

from headmotion.serve.app import create_app
from headmotion.serve.config import Limits, ServeConfig
from headmotion.serve.protocol import WS_PROTOCOL
from headmotion.web.server import running_app

SPEECH_DIR = ROOT / "examples" / "speech"


def _pcm(seconds: float) -> np.ndarray:
    """``seconds`` of the bundled speech (16 kHz), as s16le samples."""
    parts = []
    while sum(len(p) for p in parts) < seconds * 16000:
        for name in ("speech_female.wav", "speech_male.wav", "short.wav"):
            x, sr = sf.read(str(SPEECH_DIR / name), dtype="float32")
            assert sr == 16000
            parts.append(x)
    x = np.concatenate(parts)[:int(seconds * 16000)]
    return (np.clip(x, -1, 1) * 32767).astype("<i2")


@pytest.fixture(scope="module")
def server():
    app = create_app(ServeConfig(limits=Limits(send_timeout_s=1.0)), registry=registry())
    with running_app(app, ws=WS_PROTOCOL) as url:
        yield url.rstrip("/"), app.state.serve


def _offline(url: str, pcm: np.ndarray) -> np.ndarray:
    import httpx

    r = httpx.post(url + "/v1/motion", params={"model": "stream", "format": "npz", "encoding": "s16le",
                                               "sample_rate": 16000}, content=pcm.tobytes(), timeout=300)
    assert r.status_code == 200, r.text
    with np.load(io.BytesIO(r.content)) as z:
        return next(z[k] for k in z.files if z[k].ndim == 2 and z[k].shape[1] == 3)


async def _unpaced(url: str, pcm: np.ndarray, chunk: int = 160) -> tuple[np.ndarray, dict]:
    """One client sending ``chunk``-sample messages as fast as it can while reading every frame."""
    import websockets

    async with websockets.connect(url.replace("http", "ws") + "/v1/stream", max_size=None) as ws:
        await ws.send(json.dumps({"type": "start", "encoding": "s16le", "frames": "binary", "sample_rate": 16000}))
        assert json.loads(await ws.recv())["type"] == "ready"

        async def feed():
            for i in range(0, len(pcm), chunk):
                await ws.send(pcm[i:i + chunk].tobytes())
            await ws.send(json.dumps({"type": "end"}))

        sender = asyncio.create_task(feed())
        rows, end, expect = [], None, 0
        async for msg in ws:
            if isinstance(msg, bytes):
                first, n = int.from_bytes(msg[4:8], "little"), int.from_bytes(msg[8:12], "little")
                assert first == expect  # no frame lost or repeated
                expect += n
                rows.append(np.frombuffer(msg, "<f4", offset=24).reshape(n, 6)[:, :3])
            else:
                d = json.loads(msg)
                assert d["type"] != "error", d
                if d["type"] == "end":
                    end = d
        await sender
        assert ws.close_code == 1000
    return np.vstack(rows), end


def test_thirty_seconds_in_10ms_messages_unpaced_every_frame_as_post(server):
    url, st = server
    pcm = _pcm(30.0)
    got, end = asyncio.run(_unpaced(url, pcm))
    want = _offline(url, pcm)
    assert got.shape == want.shape == (750, 3) and end["frames"] == 750  # 30 s at the stream model's 25 fps
    np.testing.assert_allclose(got, want.astype(np.float32), rtol=0, atol=1e-6)


def test_eight_unpaced_clients_at_once_every_frame_as_post(server):
    url, st = server
    pcms = [_pcm(10.0 + k) for k in range(8)]  # eight lengths: eight different answers

    async def main():
        return await asyncio.gather(*[_unpaced(url, p) for p in pcms])

    results = asyncio.run(main())
    for pcm, (got, end) in zip(pcms, results):
        want = _offline(url, pcm)
        assert got.shape == want.shape and end["frames"] == len(want)
        np.testing.assert_allclose(got, want.astype(np.float32), rtol=0, atol=1e-6)
    assert st.slots.load() == 0


@pytest.fixture()
def small_buffers_server():
    """A server whose sockets have small kernel buffers (so a client that does not read fills
    them within seconds of audio rather than megabytes)."""
    import threading
    import time

    import uvicorn

    app = create_app(ServeConfig(limits=Limits(send_timeout_s=1.0)), registry=registry())
    sock = socket.socket()
    for opt in (socket.SO_SNDBUF, socket.SO_RCVBUF):  # inherited by accepted connections
        sock.setsockopt(socket.SOL_SOCKET, opt, 8192)
    sock.bind(("127.0.0.1", 0))
    server = uvicorn.Server(uvicorn.Config(app, ws=WS_PROTOCOL, lifespan="off", log_level="warning"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.02)
    try:
        yield f"http://127.0.0.1:{sock.getsockname()[1]}", app.state.serve
    finally:
        server.should_exit = True
        thread.join(timeout=5)
        sock.close()


def test_a_client_that_stops_reading_is_closed(small_buffers_server):
    """A client that sends audio and never reads: its frames fill the sockets, then the queue;
    the server stops reading its audio and, when nothing can be sent for send_timeout_s, closes
    it with too_slow and frees the slot."""
    import websockets

    url, st = small_buffers_server
    before = st.metrics.errors.labels("too_slow")._value.get()

    async def main():
        sock = socket.socket()
        for opt in (socket.SO_SNDBUF, socket.SO_RCVBUF):
            sock.setsockopt(socket.SOL_SOCKET, opt, 8192)
        host, port = url.split("//")[1].split(":")
        sock.connect((host, int(port)))
        ws = await websockets.connect(url.replace("http", "ws") + "/v1/stream", sock=sock, max_size=None)
        await ws.send(json.dumps({"type": "start", "encoding": "s16le", "frames": "json"}))
        pcm = _pcm(480.0).tobytes()  # at 25 fps a frame per 40 ms: minutes of audio before the buffers fill

        sent = [0]

        async def feed():  # never reads
            for i in range(0, len(pcm), 320):
                await ws.send(pcm[i:i + 320])
                sent[0] = i + 320

        sender = asyncio.create_task(feed())
        for _ in range(600):  # the server decides; this only bounds the wait
            await asyncio.sleep(0.1)
            if st.metrics.errors.labels("too_slow")._value.get() > before:
                break
        sender.cancel()
        await asyncio.gather(sender, return_exceptions=True)
        ws.transport.abort()
        return sent[0], len(pcm)

    sent, total = asyncio.run(main())
    assert st.metrics.errors.labels("too_slow")._value.get() == before + 1
    assert sent < total / 2  # the server stopped reading its audio long before the end
    for _ in range(100):
        if st.slots.load() == 0:
            break
        asyncio.run(asyncio.sleep(0.05))
    assert st.slots.load() == 0


def test_docs_python_client_example_gets_every_frame(server):
    """docs/serve.md's client example: a file in 160-sample float chunks, sent as fast as the
    iterator gives them."""
    from headmotion.serve.client import Client

    url, _ = server
    x, sr = sf.read(str(SPEECH_DIR / "speech_female.wav"), dtype="float32")

    async def main():
        out = []
        async for frames in Client(url).stream((x[i:i + 160] for i in range(0, len(x), 160)), sample_rate=sr):
            out.append(frames)
        return out

    got = asyncio.run(main())
    rv = np.vstack([f.rotvec for f in got])
    s = registry().models["stream"].stream(seed=0)
    want = np.vstack([s.push(x).rotvec, s.flush().rotvec])
    assert rv.shape == want.shape
    np.testing.assert_allclose(rv, want, atol=1e-6)
