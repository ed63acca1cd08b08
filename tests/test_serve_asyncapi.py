"""The stream protocol's AsyncAPI description (``/asyncapi.json``) agrees with the server: its start
message schema accepts exactly the start messages the stream accepts, every error kind the
description lists is one the docs list, and /docs lists the WebSocket route."""

from __future__ import annotations

import json

import pytest
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
    {"type": "begin"}])
def test_start_schema_accepts_what_the_stream_accepts(msg):
    ok_schema = Draft202012Validator(start_schema()).is_valid(msg)
    try:
        parse_start(json.dumps(msg))
        ok_server = True
    except ProtocolError:
        ok_server = False
    assert ok_schema == ok_server


def test_error_kinds_are_documented():
    from pathlib import Path

    docs = (Path(__file__).resolve().parents[1] / "docs" / "serve.md").read_text()
    for code, kinds in ERROR_KINDS.items():
        for k in kinds:
            assert f"`{k}`" in docs, (code, k)
