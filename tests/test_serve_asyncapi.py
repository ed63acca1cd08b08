"""The stream protocol's AsyncAPI description (``/asyncapi.json``) agrees with the server: its start
message schema accepts exactly the start messages the stream accepts, every error kind the
description lists is one the docs list, and /docs lists the WebSocket route."""

from __future__ import annotations

import json

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as hs
from jsonschema import Draft202012Validator
from serve_helpers import client

from headmotion.serve.asyncapi import ERROR_KINDS, document, start_schema
from headmotion.serve.stream import START_FIELDS, ProtocolError, parse_start


def test_document_structure():
    with client() as c:
        doc = c.get("/asyncapi.json").json()
        assert doc == json.loads(json.dumps(document(doc["info"]["version"])))
        assert doc["asyncapi"] == "3.0.0" and doc["channels"]["stream"]["address"] == "/v1/stream"
        for op in doc["operations"].values():  # every reference resolves
            for ref in op["messages"]:
                name = ref["$ref"].rsplit("/", 1)[1]
                assert ref["$ref"] == f"#/channels/stream/messages/{name}"
                assert doc["channels"]["stream"]["messages"][name]["$ref"] == f"#/components/messages/{name}"
                assert name in doc["components"]["messages"]
        schema = c.get("/openapi.json").json()
        assert "/v1/stream" in schema["paths"] and "/asyncapi.json" in schema["info"]["description"]
        r = c.get("/v1/stream")
        assert r.status_code == 426 and r.json()["error"] == "upgrade_required"
    assert set(start_schema()["properties"]) == START_FIELDS


@pytest.mark.parametrize("msg", [
    {"type": "start"}, {"type": "start", "gain": [0, 10, 1], "offset": -90, "seed": 2 ** 32 - 1},
    {"type": "start", "encoding": "f32le", "frames": "binary", "resample": "fast", "sample_rate": 44100},
    {"type": "start", "gain": -1}, {"type": "start", "gain": [1, 11, 1]}, {"type": "start", "offset": [0, 91, 0]},
    {"type": "start", "seed": 2 ** 32}, {"type": "start", "seed": -1}, {"type": "start", "sample_rate": 7999},
    {"type": "start", "encoding": "mulaw"}, {"type": "start", "resample": "best"}, {"type": "start", "colour": 1},
    {"type": "begin"}, {"type": "start", "seed": 3.0, "sample_rate": 16000.0}, {"type": "start", "seed": 3.5},
    {"type": "start", "sample_rate": None, "gain": None, "model": None}, {"type": "start", "seed": None}])
def test_start_schema_accepts_what_the_stream_accepts(msg):
    ok_schema = Draft202012Validator(start_schema()).is_valid(msg)
    try:
        parse_start(json.dumps(msg))
        ok_server = True
    except ProtocolError:
        ok_server = False
    assert ok_schema == ok_server


values = hs.one_of(hs.none(), hs.booleans(), hs.integers(-10, 2 ** 33), hs.floats(-300, 300), hs.text(max_size=6),
                   hs.integers(-10, 200000).map(float),
                   hs.lists(hs.one_of(hs.floats(-300, 300), hs.integers(-5, 200), hs.booleans()), max_size=4),
                   hs.sampled_from(["stream", "s16le", "f32le", "json", "binary", "exact", "fast", 16000, 44100]))
fields = hs.sampled_from(sorted(START_FIELDS - {"type"}) + ["extra"])


def _near_a_bound(v) -> bool:
    """Within 1e-6 of a range's end but not on it (the server allows rounding of degrees there)."""
    xs = v if isinstance(v, list) else [v]
    return any(isinstance(x, float) and any(0 < abs(x - b) < 1e-6 for b in (0, 10, -90, 90)) for x in xs)


@settings(max_examples=500, deadline=None)
@given(msg=hs.dictionaries(fields, values, max_size=6))
def test_start_schema_and_server_agree_on_any_start(msg):
    assume(not any(_near_a_bound(v) for v in msg.values()))
    test_start_schema_accepts_what_the_stream_accepts({"type": "start", **msg})


def test_error_kinds_are_documented():
    from pathlib import Path

    docs = (Path(__file__).resolve().parents[1] / "docs" / "serve.md").read_text()
    for code, kinds in ERROR_KINDS.items():
        for k in kinds:
            assert f"`{k}`" in docs, (code, k)
