"""Fuzz of the stream protocol (hypothesis): whatever a client sends — a start message with random
fields, binary of any length, text, in any order — the server either streams (ready, frames with
contiguous numbers, end) or answers exactly one error and closes; it never fails internally, never
leaves a stream slot taken, and keeps serving."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs
from serve_helpers import WS, client, read_until_close

scalars = hs.one_of(hs.none(), hs.booleans(), hs.integers(-10, 200000), hs.floats(allow_nan=True),
                    hs.text(max_size=8), hs.lists(hs.floats(-5, 5), max_size=4))
start_fields = hs.dictionaries(
    hs.sampled_from(["model", "sample_rate", "encoding", "seed", "frames", "gain", "offset", "still", "extra"]),
    hs.one_of(scalars, hs.sampled_from(["stream", "s16le", "f32le", "json", "binary", 16000, 48000])), max_size=6)
start_msg = hs.one_of(
    start_fields.map(lambda d: json.dumps({"type": "start", **d})),
    hs.text(max_size=30), hs.binary(max_size=30))
later = hs.one_of(hs.binary(max_size=4000), hs.just('{"type": "end"}'), hs.text(max_size=20),
                  hs.sampled_from([b"", b"\x00", json.dumps({"type": "end", "n": 1})]))


@pytest.fixture(scope="module")
def c():
    with client(max_message_bytes=3000, idle_timeout_s=2.0, start_timeout_s=2.0) as cl:
        yield cl


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(first=start_msg, rest=hs.lists(later, max_size=6))
def test_stream_protocol_fuzz(c, first, rest):
    with c.websocket_connect(WS) as ws:
        for m in [first, *rest]:
            ws.send_bytes(m) if isinstance(m, bytes) else ws.send_text(m)
        if not rest or rest[-1] != '{"type": "end"}':
            ws.send_text('{"type": "end"}')  # a well-behaved client ends; the server must end or refuse
        out = read_until_close(ws)
    texts = [json.loads(m["text"]) for m in out if m.get("text")]
    errors = [t for t in texts if t["type"] == "error"]
    close = out[-1]["code"]
    if errors:
        assert len(errors) == 1 and errors[0]["error"] != "internal", errors
        assert close in (1007, 1008, 1009, 1013) and out[-1]["reason"].startswith(errors[0]["error"])
    else:
        assert close == 1000 and texts[0]["type"] == "ready" and texts[-1]["type"] == "end"
        n = sum(len(t["frames"]) for t in texts if t["type"] == "frames")
        nb = sum(int.from_bytes(m["bytes"][8:12], "little") for m in out if m.get("bytes") is not None)
        assert texts[-1]["frames"] == n + nb
    assert c.get("/readyz").json()["open_streams"] == 0
