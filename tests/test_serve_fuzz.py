"""Fuzz of the stream protocol (hypothesis): whatever a client sends — a start message with random
fields, binary of any length, text, in any order — the server either streams (ready, frames with
contiguous numbers, end) or answers exactly one error and closes; it never fails internally, never
leaves a stream slot taken, and keeps serving.  Fuzz of the offline controls: any gain, offset,
seed, samples, fps or unknown parameter answers 200 exactly when every value is within its
stated range, else 400 ``bad_parameter`` naming the range or the parameter."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs
from serve_helpers import WS, client, read_until_close

from headmotion.synthesis import GAIN_RANGE, OFFSET_RANGE_DEG, SEED_MAX

scalars = hs.one_of(hs.none(), hs.booleans(), hs.integers(-10, 200000), hs.floats(allow_nan=True),
                    hs.text(max_size=8), hs.lists(hs.floats(-5, 5), max_size=4),
                    hs.integers(2 ** 32 - 3, 2 ** 70), hs.floats(-200, 200), hs.lists(hs.floats(-200, 200), min_size=3, max_size=3))
start_fields = hs.dictionaries(
    hs.sampled_from(["model", "sample_rate", "encoding", "seed", "frames", "gain", "offset", "still", "resample",
                     "extra"]),
    hs.one_of(scalars, hs.sampled_from(["stream", "s16le", "f32le", "json", "binary", "exact", "fast", 16000,
                                        48000])), max_size=6)
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


numbers = hs.one_of(hs.floats(-1e9, 1e9, allow_nan=False), hs.sampled_from([0, 10, -90, 90, 10.0001, -90.001, 1e308]))
offline_query = hs.fixed_dictionaries({}, optional={
    "gain": numbers, "gain_yaw": numbers, "offset": numbers, "offset_pitch": numbers,
    "seed": hs.one_of(hs.integers(-5, 2 ** 70), hs.just(SEED_MAX)), "samples": hs.integers(0, 20),
    "fps": hs.floats(0, 2000), "gain_ptich": numbers, "colour": hs.text("abc", min_size=1, max_size=3)})


def _in_range(q: dict) -> bool:
    gains = [q[k] for k in ("gain", "gain_yaw") if k in q]
    offsets = [q[k] for k in ("offset", "offset_pitch") if k in q]
    samples = q.get("samples", 1)
    return (all(GAIN_RANGE[0] - 1e-9 <= g <= GAIN_RANGE[1] + 1e-9 for g in gains)  # the checks' rounding tolerance
            and all(OFFSET_RANGE_DEG[0] <= math.degrees(math.radians(o)) <= OFFSET_RANGE_DEG[1] + 1e-9 for o in offsets)
            and 1 <= samples <= 16 and 0 <= q.get("seed", 0) <= SEED_MAX - (samples - 1)
            and 1 <= q.get("fps", 100) <= 1000 and "gain_ptich" not in q and "colour" not in q)


@pytest.fixture(scope="module")
def pcm():
    rng = np.random.default_rng(0)
    return (0.1 * rng.standard_normal(4000)).astype("<f4").tobytes()  # 0.25 s


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(q=offline_query)
def test_offline_controls_fuzz(c, pcm, q):
    r = c.post("/v1/motion", params={"model": "stream", "encoding": "f32le", "sample_rate": 16000,
                                     "format": "csv", **{k: repr(v) if isinstance(v, float) else v for k, v in q.items()}},
               content=pcm)
    if _in_range(q):
        assert r.status_code == 200, (q, r.text)
    else:
        assert r.status_code == 400, (q, r.text)
        body = r.json()
        assert set(body) == {"error", "detail"} and body["error"] == "bad_parameter", body
        assert any(word in body["detail"] for word in ("between", "0 to", "unknown query", "less than",
                                                       "greater than")), body
