"""``WS /v1/stream`` with what the head hears: hear messages (base64 PCM at their own rate and
encoding) give the frames of ``synthesize(speech, hear=other)``; bad hear messages get one clear
error."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
import pytest
from serve_helpers import WS, client, read_until_close, start

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "speech"


@pytest.fixture(scope="module")
def c():
    with client() as cl:
        yield cl


def conversation():
    from headmotion.io import load_audio

    sr = 16000
    a = load_audio(EXAMPLES / "speech_female.wav", sample_rate=sr).samples[:4 * sr]
    b = load_audio(EXAMPLES / "speech_male.wav", sample_rate=sr).samples[:8 * sr]
    gap = np.zeros(sr // 2, np.float32)
    own = np.concatenate([a, gap, np.zeros_like(b), gap])
    heard = np.concatenate([np.zeros_like(a), gap, b, gap])
    return own, heard


def frames_of(msgs):
    rows = []
    for m in msgs[:-1]:
        d = json.loads(m["text"])
        if d["type"] == "frames":
            rows += [f["rotvec"] for f in d["frames"]]
    return np.array(rows)


def test_heard_audio_gives_the_listening_head_of_synthesize(c):
    from headmotion.synthesis import synthesize
    from headmotion.types import Audio

    own, heard = conversation()
    heard48 = np.repeat(heard, 3)  # the other party at 48 kHz, as float32
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(sample_rate=16000, encoding="f32le", seed=1,
                           hear={"sample_rate": 48000, "encoding": "f32le"}))
        ready = json.loads(ws.receive_text())
        assert ready["hear"] == {"sample_rate": 48000, "encoding": "f32le"} and ready["listening"] == 1.0
        for i in range(0, len(own), 320):
            ws.send_text(json.dumps({"type": "hear", "audio": base64.b64encode(
                heard48[3 * i:3 * (i + 320)].astype("<f4").tobytes()).decode()}))
            ws.send_bytes(own[i:i + 320].astype("<f4").tobytes())
        ws.send_text(json.dumps({"type": "end"}))
        msgs = read_until_close(ws)
    got = frames_of(msgs)
    want = synthesize(Audio(own, 16000), "stream", seed=1, hear=Audio(heard48, 48000))[0]
    assert len(want.meta["nod_frames"]) >= 1
    np.testing.assert_allclose(got, want.rotvec, atol=2e-6)  # the JSON's 6 decimals


@pytest.mark.parametrize("msg, kind, code", [
    ({"type": "hear", "audio": "not base64!"}, "bad_audio", 1007),
    ({"type": "hear", "audio": base64.b64encode(b"abc").decode()}, "bad_audio", 1007),
    ({"type": "hear", "audio": "", "extra": 1}, "bad_message", 1008),
])
def test_bad_hear_messages_one_error_then_close(c, msg, kind, code):
    with c.websocket_connect(WS) as ws:
        ws.send_text(start())
        json.loads(ws.receive_text())
        ws.send_text(json.dumps(msg))
        msgs = read_until_close(ws)
    err = json.loads(msgs[0]["text"])
    assert err["error"] == kind and msgs[-1]["code"] == code


@pytest.mark.parametrize("fields, words", [
    ({"hear": {"sample_rate": 7}}, "hear.sample_rate"),
    ({"hear": {"encoding": "mp3"}}, "hear.encoding"),
    ({"hear": "yes"}, "hear must be"),
    ({"listening": 9}, "listening"),
])
def test_bad_hear_start_fields(c, fields, words):
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(**fields))
        msgs = read_until_close(ws)
    err = json.loads(msgs[0]["text"])
    assert err["error"] == "bad_start" and words in err["detail"]
