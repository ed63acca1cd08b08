"""``WS /v1/stream``: the frames equal the library's stream of the same samples (none lost or
duplicated), both frame formats, the end message; each malformed message gets one clear error and
a closed connection; back-pressure closes a client that falls behind; a vanished client frees its
slot."""

from __future__ import annotations

import asyncio
import json
import time

import numpy as np
import pytest
from serve_helpers import WS, client, read_until_close, registry, speech_f32, start

from headmotion.serve.stream import parse_binary_frames


@pytest.fixture(scope="module")
def c():
    with client() as cl:
        yield cl


def library_frames(x, chunk, seed=0):
    s = registry().models["stream"].stream(seed=seed)
    parts = [s.push(x[i:i + chunk]).rotvec for i in range(0, len(x), chunk)] + [s.flush().rotvec]
    return np.vstack(parts)


def run_stream(c, x, chunk, fmt, seed=0, encoding="f32le"):
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(encoding=encoding, frames=fmt, seed=seed, sample_rate=16000))
        ready = json.loads(ws.receive_text())
        assert ready["type"] == "ready" and ready["fps"] == 25.0 and 0 < ready["latency_ms"] < 200
        for i in range(0, len(x), chunk):
            part = x[i:i + chunk]
            ws.send_bytes(part.astype("<f4").tobytes() if encoding == "f32le"
                          else (np.clip(part, -1, 1) * 32767).astype("<i2").tobytes())
        ws.send_text(json.dumps({"type": "end"}))
        msgs = read_until_close(ws)
    assert msgs[-1]["code"] == 1000
    firsts, rows, end = [], [], None
    for m in msgs[:-1]:
        if m.get("bytes") is not None:
            first, fps, t, a = parse_binary_frames(m["bytes"])
            firsts.append((first, len(a)))
            rows.append(a[:, :3])
        else:
            d = json.loads(m["text"])
            if d["type"] == "end":
                end = d
                continue
            assert d["type"] == "frames" and d["audio_time"] >= d["frames"][-1]["time"] - 1.0
            assert [f["frame"] for f in d["frames"]] == list(range(d["first"], d["first"] + len(d["frames"])))
            firsts.append((d["first"], len(d["frames"])))
            rows.append(np.array([f["rotvec"] for f in d["frames"]]))
    expect = 0
    for first, n in firsts:  # contiguous: no frame lost, none twice
        assert first == expect
        expect += n
    assert end == {"type": "end", "frames": expect, "audio_seconds": round(len(x) / 16000, 4)}
    return np.vstack(rows)


@pytest.mark.parametrize("chunk", [160, 1000, 7])
def test_stream_equals_library_binary(c, chunk):
    x = speech_f32()
    got = run_stream(c, x, chunk, "binary", seed=2)
    want = library_frames(x, 160, seed=2)
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want.astype(np.float32), rtol=0, atol=1e-7)


def test_stream_equals_library_json_s16(c):
    x = speech_f32()
    q = (np.clip(x, -1, 1) * 32767).astype("<i2").astype(np.float32) / 32768
    got = run_stream(c, x, 160, "json", encoding="s16le")
    np.testing.assert_allclose(got, library_frames(q, 160), atol=1e-6)


def test_stream_resamples_other_rates(c):
    import soxr

    x = soxr.resample(speech_f32(), 16000, 48000).astype(np.float32)
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(encoding="f32le", sample_rate=48000))
        assert json.loads(ws.receive_text())["sample_rate"] == 48000
        for i in range(0, len(x), 480):
            ws.send_bytes(x[i:i + 480].tobytes())
        ws.send_text('{"type": "end"}')
        msgs = read_until_close(ws)
    end = json.loads(msgs[-2]["text"])
    assert abs(end["frames"] - 2.78 * 25) <= 1  # 2.78 s at the stream model's 25 fps


BAD = [
    ("binary first", [b"\x00\x00"], "bad_start", 1008),
    ("not json", ["hello"], "bad_start", 1008),
    ("wrong type", [json.dumps({"type": "begin"})], "bad_start", 1008),
    ("unknown field", [start(rate=16000)], "bad_start", 1008),
    ("bad rate", [start(sample_rate=100)], "bad_start", 1008),
    ("bad encoding", [start(encoding="mulaw")], "bad_start", 1008),
    ("encoding not text", [start(encoding=[])], "bad_start", 1008),
    ("frames not text", [start(frames={})], "bad_start", 1008),
    ("bad gain", [start(gain=[1, 2])], "bad_start", 1008),
    ("unknown model", [start(model="nope")], "unknown_model", 1008),
    ("odd bytes", [start(encoding="s16le"), b"\x00\x01\x02"], "bad_audio", 1007),
    ("nan", [start(encoding="f32le"), np.array([np.nan] * 4, "<f4").tobytes()], "bad_audio", 1007),
    ("huge frame", [start(), b"\x00" * 3000], "too_large", 1009),
    ("text where binary is due", [start(), "more audio"], "bad_message", 1008),
    ("end with extras", [start(), json.dumps({"type": "end", "x": 1})], "bad_message", 1008),
    ("settle out of range", [start(settle=9)], "bad_start", 1008),
    ("lookahead out of range", [start(lookahead_ms=1081)], "bad_start", 1008),
    ("lookahead negative", [start(lookahead_ms=-40)], "bad_start", 1008),
    ("lookahead not a number", [start(lookahead_ms="200")], "bad_start", 1008),
    ("interrupt shows unsent frames", [start(), json.dumps({"type": "interrupt", "shown": 5})], "bad_message", 1008),
]


@pytest.mark.parametrize("lookahead_ms, chunk", [(200, 160), (400, 1000), (1080, 7)])
def test_a_stream_with_a_lookahead_equals_synthesize_with_it(c, lookahead_ms, chunk):
    """``lookahead_ms`` in the start message: the frames the server sends are those of
    ``synthesize(model="stream", lookahead_ms=L)`` on the same audio, and the ready message's
    latency has grown by the whole frames read ahead (40 ms each)."""
    from headmotion import synthesize
    from headmotion.types import Audio

    x = speech_f32()
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(encoding="f32le", sample_rate=16000, frames="json", lookahead_ms=lookahead_ms))
        ready = json.loads(ws.receive_text())
        for i in range(0, len(x), chunk):
            ws.send_bytes(x[i:i + chunk].tobytes())
        ws.send_text('{"type": "end"}')
        msgs = read_until_close(ws)
    texts = [json.loads(m["text"]) for m in msgs if m.get("text")]
    got = np.array([f["rotvec"] for d in texts if d["type"] == "frames" for f in d["frames"]])
    want = synthesize(Audio(x, 16000), model="stream", lookahead_ms=lookahead_ms)[0].rotvec
    assert got.shape == want.shape and texts[-1]["frames"] == len(want)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)
    base = registry().models["stream"].stream(seed=0).latency_ms
    assert ready["lookahead_ms"] == lookahead_ms
    assert ready["latency_ms"] == pytest.approx(base + 40.0 * (lookahead_ms * 25 // 1000))


def test_a_lookahead_on_a_model_that_is_not_live_is_refused():
    """The shipped default reads ahead already (it is not live): a lookahead for it is refused with
    ``bad_start`` naming why, and the connection closes."""
    with client(names=("stream", "default")) as cl:
        with cl.websocket_connect(WS) as ws:
            ws.send_text(start(model="default", lookahead_ms=200))
            out = read_until_close(ws)
    err = json.loads(out[0]["text"])
    assert err["error"] == "bad_start" and "lookahead_ms" in err["detail"] and "not live" in err["detail"]
    assert out[-1]["code"] == 1008


@pytest.mark.parametrize("name,msgs,kind,code", BAD, ids=[b[0] for b in BAD])
def test_malformed_messages_one_error_then_close(name, msgs, kind, code):
    with client(max_message_bytes=2000) as cl:
        with cl.websocket_connect(WS) as ws:
            for m in msgs:
                ws.send_bytes(m) if isinstance(m, bytes) else ws.send_text(m)
            out = read_until_close(ws)
        texts = [json.loads(m["text"]) for m in out if m.get("text")]
        errors = [t for t in texts if t["type"] == "error"]
        assert len(errors) == 1 and errors[0]["error"] == kind and len(errors[0]["detail"]) > 10, texts
        assert out[-1]["code"] == code and out[-1]["reason"].startswith(kind)
        # the server carries on
        assert cl.get("/readyz").json()["open_streams"] == 0
        run = cl.post("/v1/motion", content=speech_f32()[:16000].tobytes(),
                      params={"model": "stream", "encoding": "f32le", "sample_rate": 16000})
        assert run.status_code == 200


def test_idle_and_length_limits():
    with client(idle_timeout_s=0.3, max_stream_seconds=0.5) as cl:
        with cl.websocket_connect(WS) as ws:
            ws.send_text(start(encoding="f32le"))
            ws.receive_text()
            out = read_until_close(ws)
        assert json.loads(out[0]["text"])["error"] == "idle"
        with cl.websocket_connect(WS) as ws:
            ws.send_text(start(encoding="f32le"))
            ws.receive_text()
            for _ in range(10):
                ws.send_bytes(np.zeros(1600, "<f4").tobytes())
            out = read_until_close(ws)
        err = [json.loads(m["text"]) for m in out if m.get("text") and '"error"' in m["text"]]
        assert err[0]["error"] == "too_long" and out[-1]["code"] == 1009


def test_vanished_client_frees_its_slot(tmp_path):
    with client(tmp_path, keys=[("k1", "one", 1, 600)]) as cl:
        hdr = {"authorization": "Bearer k1"}
        for _ in range(3):  # one slot: each stream must free it when its client vanishes
            with cl.websocket_connect(WS, headers=hdr) as ws:
                ws.send_text(start(encoding="f32le"))
                assert json.loads(ws.receive_text())["type"] == "ready"
                ws.send_bytes(np.zeros(1600, "<f4").tobytes())
            deadline = time.time() + 5
            while cl.get("/readyz", headers=hdr).json()["open_streams"] and time.time() < deadline:
                time.sleep(0.01)
            assert cl.get("/readyz", headers=hdr).json()["open_streams"] == 0
        assert "open_streams" not in cl.get("/readyz").json()  # the load is shown to key holders only


class _StuckSocket:
    """A WebSocket whose client never reads: every send waits forever."""

    def __init__(self, st, n_chunks):
        self.app = type("A", (), {"state": type("S", (), {"serve": st})()})()
        self.scope = {"headers": []}
        self.incoming = [{"type": "websocket.receive", "text": start(encoding="f32le")}] + [
            {"type": "websocket.receive", "bytes": np.zeros(160, "<f4").tobytes()} for _ in range(n_chunks)]
        self.sent, self.closed = [], None

    async def accept(self):
        pass

    async def receive(self):
        await asyncio.sleep(0)
        return self.incoming.pop(0) if self.incoming else {"type": "websocket.disconnect"}

    async def send_text(self, text):
        if '"error"' in text:
            self.sent.append(text)
            return
        await asyncio.Event().wait()

    send_bytes = send_text

    async def close(self, code=1000, reason=None):
        self.closed = (code, reason)


def test_back_pressure_closes_a_client_that_falls_behind():
    from headmotion.serve.app import create_app
    from headmotion.serve.config import Limits, ServeConfig
    from headmotion.serve.stream import Session

    app = create_app(ServeConfig(limits=Limits(queue_messages=5, send_timeout_s=0.2)), registry=registry())
    st = app.state.serve
    ws = _StuckSocket(st, 3000)  # 30 s of audio, ~one frames message per chunk
    asyncio.run(Session(ws, st).run())
    assert ws.closed[0] == 1008 and ws.closed[1].startswith("too_slow")
    assert json.loads(ws.sent[-1])["error"] == "too_slow"
    assert len(ws.incoming) > 2900  # closed soon after the queue filled, not after reading everything
    assert st.slots.total() == 0


def _frames_and_end(msgs):
    """The frames (number → (rotvec, settling)) and the end message of a JSON-frames stream; a
    settling after an interruption renumbers frames from ``shown`` (later frames replace)."""
    rows, end = {}, None
    for m in msgs[:-1]:
        d = json.loads(m["text"])
        if d["type"] == "end":
            end = d
        elif d["type"] == "frames":
            for f in d["frames"]:
                rows[f["frame"]] = np.array(f["rotvec"])
    return rows, end


def test_end_settles_the_head_to_rest_plus_offset(c):
    """``settle`` 0.5 s at 25 fps: after the speech's frames (those the library gives), 13 more
    that leave the last pose and reach the offset pose exactly; the end counts them."""
    from headmotion.rotations import pitch_yaw_roll_to_rotvec

    x = speech_f32()
    want = library_frames(x, 160)
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(encoding="f32le", sample_rate=16000, settle=0.5, offset=[3, 0, 0]))
        assert json.loads(ws.receive_text())["settle"] == 0.5
        for i in range(0, len(x), 1600):
            ws.send_bytes(x[i:i + 1600].tobytes())
        ws.send_text('{"type": "end"}')
        rows, end = _frames_and_end(read_until_close(ws))
    n = len(want)
    assert end["frames"] == n + 13 and sorted(rows) == list(range(n + 13))
    rest = np.asarray(pitch_yaw_roll_to_rotvec(np.radians(3.0), 0.0, 0.0)).reshape(3)
    np.testing.assert_allclose(rows[n + 12], rest, atol=1e-6)
    # the speech's frames carry the offset; the settling starts where they stop, without a jump
    steps = [np.linalg.norm(rows[k + 1] - rows[k]) for k in range(n - 5, n + 12)]
    assert max(steps) < 0.02
    assert "interrupted" not in end


def test_interrupt_settles_from_the_last_frame_shown(c):
    """Cut off after 40 frames were shown: the settling replaces frames 40… (numbered from 40),
    starts from frame 39's pose and reaches rest; the end says interrupted, frames 40 + 13."""
    x = speech_f32()
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(encoding="f32le", sample_rate=16000, settle=0.5))
        json.loads(ws.receive_text())
        for i in range(0, len(x), 1600):
            ws.send_bytes(x[i:i + 1600].tobytes())
        early = {}
        while len(early) < 50:  # until at least 50 frames came back
            d = json.loads(ws.receive_text())
            early.update({f["frame"]: np.array(f["rotvec"]) for f in d["frames"]})
        frame39, frame38 = early[39], early[38]
        ws.send_text(json.dumps({"type": "interrupt", "shown": 40}))
        msgs = read_until_close(ws)
    rows, end = _frames_and_end(msgs)
    assert end["interrupted"] is True and end["frames"] == 40 + 13
    settling = np.array([rows[k] for k in range(40, 53)])
    np.testing.assert_allclose(settling[-1], np.zeros(3), atol=1e-9)
    # the settling of the live core from frames 39 and 38 (the JSON frames carry 6 decimals)
    from headmotion.live.core import settle_path

    np.testing.assert_allclose(settling, settle_path(frame39, frame38, np.zeros(3), 13), atol=2e-6)
    assert msgs[-1]["code"] == 1000
