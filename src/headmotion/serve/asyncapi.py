"""The stream protocol (``WS /v1/stream``) as an AsyncAPI 3.0 document, served at
``/asyncapi.json`` beside the OpenAPI description of the HTTP routes (``/openapi.json``).

Built from the constants the stream checks its messages with (:mod:`headmotion.serve.stream`,
the controls' ranges of :mod:`headmotion.synthesis`), so the description and the server agree;
docs/serve.md tells the same in prose.
"""

from __future__ import annotations

from ..synthesis import AMOUNT_RANGE, GAIN_RANGE, LOOKAHEAD_RANGE_MS, OFFSET_RANGE_DEG, SEED_MAX

#: close codes and the error kinds that come with them (docs/serve.md "Errors")
ERROR_KINDS = {
    1008: ["bad_start", "bad_message", "unauthorized", "unknown_model", "idle", "too_slow", "not_found"],
    1007: ["bad_audio"],
    1009: ["too_large", "too_long"],
    1013: ["too_many_streams", "rate_limited", "busy", "not_ready"],
    1011: ["internal"],
}


def _number_or_triple(lo: float, hi: float, unit: str) -> dict:
    one = {"type": "number", "minimum": lo, "maximum": hi}
    return {"oneOf": [one, {"type": "array", "items": one, "minItems": 3, "maxItems": 3}, {"type": "null"}],
            "description": f"One value or [pitch, yaw, roll], each {lo:g} to {hi:g}{unit}; null: the default."}


def start_schema() -> dict:
    """JSON schema of the start message (what :func:`headmotion.serve.stream.parse_start` accepts)."""
    from ..listener import LISTENING_RANGE
    from ..live.core import SETTLE_RANGE_S
    from .stream import ENCODINGS, RESAMPLE

    return {
        "type": "object", "additionalProperties": False, "required": ["type"],
        "properties": {
            "type": {"const": "start"},
            "model": {"type": ["string", "null"], "description": "A name from GET /v1/models (default: stream)."},
            "sample_rate": {"type": ["integer", "null"], "minimum": 8000, "maximum": 192000,
                            "description": "Rate of the audio sent (default: the model's)."},
            "encoding": {"enum": sorted(ENCODINGS), "default": "s16le"},
            "seed": {"type": ["integer", "null"], "minimum": 0, "maximum": SEED_MAX, "default": None,
                     "description": "Synthesis seed (default: the model's own, 0 for the shipped models)."},
            "frames": {"enum": ["json", "binary"], "default": "json"},
            "amount": {"type": "number", "minimum": AMOUNT_RANGE[0], "maximum": AMOUNT_RANGE[1], "default": 1,
                       "description": "How much the head moves: 1 natural, 2 animated, 0.5 calm, 0 still (the "
                                      "choice of recorded movements; motion-matching models)."},
            "gain": _number_or_triple(*GAIN_RANGE, ""),
            "offset": _number_or_triple(*OFFSET_RANGE_DEG, " degrees"),
            "still": {"type": "boolean", "default": False},
            "resample": {"enum": sorted(RESAMPLE), "default": "exact",
                         "description": "exact: resampled as POST /v1/motion does, the same frames; fast: "
                                        "~10 ms less delay, frames that may differ by a few degrees."},
            "api_key": {"type": ["string", "null"], "description": "For browsers, which cannot set headers on a WebSocket; "
                                                         "programs send Authorization: Bearer KEY."},
            "hear": {"oneOf": [{"type": "boolean"}, {"type": "null"}, {
                "type": "object", "additionalProperties": False, "properties": {
                    "sample_rate": {"type": ["integer", "null"], "minimum": 8000, "maximum": 192000},
                    "encoding": {"enum": sorted(ENCODINGS)}}}],
                "description": "Rate and encoding of the other party's audio (hear messages); default: the "
                               "speech's."},
            "listening": {"type": "number", "minimum": LISTENING_RANGE[0], "maximum": LISTENING_RANGE[1], "default": 1,
                          "description": "How much the head listens while the other speaks: 0 only waits, 1 an "
                                         "attentive posture and back-channel nods at the other's cues, up to 3."},
            "settle": {"type": "number", "minimum": SETTLE_RANGE_S[0], "maximum": SETTLE_RANGE_S[1], "default": 0,
                       "description": "Seconds of frames easing the head to rest (plus the offset) after the end "
                                      "or an interruption; 0: none."},
            "lookahead_ms": {"type": "number", "minimum": LOOKAHEAD_RANGE_MS[0], "maximum": LOOKAHEAD_RANGE_MS[1],
                             "default": 0,
                             "description": "Milliseconds a live model (the shipped stream) reads the speech ahead "
                                            "of each frame, for speech made before it plays (a voice agent's TTS): "
                                            "latency_ms grows by floor(lookahead_ms * fps / 1000) frames. 0: causal; "
                                            "another value on a model that is not live: bad_start."},
        },
    }


def document(version: str = "0") -> dict:
    """The AsyncAPI 3.0 document of the stream protocol."""
    frame = {"type": "object", "required": ["frame", "time", "rotvec", "pitch_yaw_roll_deg"], "properties": {
        "frame": {"type": "integer", "minimum": 0}, "time": {"type": "number"},
        "rotvec": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3,
                   "description": "Rotation vector, radians."},
        "pitch_yaw_roll_deg": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}}}
    kinds = sorted(k for ks in ERROR_KINDS.values() for k in ks)
    messages = {
        "start": {"name": "start", "title": "Start (first message, text)", "contentType": "application/json",
                  "payload": start_schema()},
        "audio": {"name": "audio", "title": "Audio (binary)", "contentType": "application/octet-stream",
                  "payload": {"type": "string", "format": "binary",
                              "description": "Mono PCM in the start message's encoding, any whole number of "
                                             "samples per message (at most 1 MiB)."}},
        "hear": {"name": "hear", "title": "The other party's audio (text)", "contentType": "application/json",
                 "payload": {"type": "object", "additionalProperties": False, "required": ["type", "audio"],
                             "properties": {"type": {"const": "hear"}, "audio": {
                                 "type": "string", "contentEncoding": "base64",
                                 "description": "Mono PCM in the start message's hear encoding and rate, any "
                                                "whole number of samples; heard sample k is at time k / rate "
                                                "from the start, on the speech's timeline."}}}},
        "end": {"name": "end", "title": "End (text)", "contentType": "application/json",
                "payload": {"type": "object", "additionalProperties": False, "required": ["type"],
                            "properties": {"type": {"const": "end"}}}},
        "interrupt": {"name": "interrupt", "title": "Interrupt (text): the speech is cut off",
                      "contentType": "application/json",
                      "payload": {"type": "object", "additionalProperties": False, "required": ["type"],
                                  "properties": {"type": {"const": "interrupt"}, "shown": {
                                      "type": ["integer", "null"], "minimum": 0,
                                      "description": "Frames the client showed (at most those sent; default: "
                                                     "all sent): the head settles from frame shown - 1, the "
                                                     "settling numbered from shown."}}}},
        "ready": {"name": "ready", "title": "Ready", "contentType": "application/json", "payload": {
            "type": "object", "required": ["type", "model", "fps", "latency_ms"], "properties": {
                "type": {"const": "ready"}, "model": {"type": "string"}, "system": {"type": "string"},
                "fps": {"type": "number"}, "latency_ms": {"type": "number"}, "sample_rate": {"type": "integer"},
                "model_sample_rate": {"type": "integer"}, "encoding": {"type": "string"},
                "frames": {"type": "string"}, "hear": {"type": "object"}, "listening": {"type": "number"},
                "settle": {"type": "number"}, "lookahead_ms": {"type": "number"}}}},
        "frames": {"name": "frames", "title": "Frames (JSON)", "contentType": "application/json", "payload": {
            "type": "object", "required": ["type", "first", "fps", "audio_time", "frames"], "properties": {
                "type": {"const": "frames"}, "first": {"type": "integer", "minimum": 0}, "fps": {"type": "number"},
                "audio_time": {"type": "number", "description": "Audio seconds the server had received."},
                "frames": {"type": "array", "items": frame}}}},
        "framesBinary": {"name": "framesBinary", "title": "Frames (binary)", "contentType": "application/octet-stream",
                         "payload": {"type": "string", "format": "binary",
                                     "description": "24-byte little-endian header <4s I I f d> = (b'HMF1', first "
                                                    "frame, frame count, fps, audio seconds received), then per "
                                                    "frame six float32: rotation vector (radians), pitch, yaw, "
                                                    "roll (degrees)."}},
        "ended": {"name": "ended", "title": "End of the stream", "contentType": "application/json", "payload": {
            "type": "object", "required": ["type", "frames", "audio_seconds"], "properties": {
                "type": {"const": "end"}, "frames": {"type": "integer"}, "audio_seconds": {"type": "number"},
                "interrupted": {"type": "boolean", "description": "The speech was cut off (interrupt)."}}}},
        "error": {"name": "error", "title": "Error, then a close whose reason starts with the kind",
                  "contentType": "application/json", "payload": {
                      "type": "object", "required": ["type", "error", "detail"], "properties": {
                          "type": {"const": "error"}, "error": {"enum": kinds}, "detail": {"type": "string"},
                          "retry_after": {"type": "integer", "description": "Seconds (rate_limited, busy, "
                                                                            "not_ready)."}}},
                  "description": "Close codes: " + "; ".join(f"{c}: {', '.join(ks)}" for c, ks in ERROR_KINDS.items())
                                 + ". 1012 (no error message): the server restarts; reconnect."},
    }

    def op(action, names, summary):
        return {"action": action, "channel": {"$ref": "#/channels/stream"}, "summary": summary,
                "messages": [{"$ref": f"#/channels/stream/messages/{n}"} for n in names]}

    return {
        "asyncapi": "3.0.0",
        "info": {"title": "headmotion serve: stream", "version": version,
                 "description": "Speech in as it arrives, head motion out as it becomes final. The HTTP routes "
                                "are in /openapi.json; docs/serve.md has examples."},
        "defaultContentType": "application/json",
        "channels": {"stream": {"address": "/v1/stream", "title": "WS /v1/stream",
                                "messages": {n: {"$ref": f"#/components/messages/{n}"} for n in messages}}},
        "operations": {
            "receiveStart": op("receive", ["start"], "The client's first message (Authorization: Bearer KEY on "
                                                     "the handshake, or api_key here)."),
            "receiveAudio": op("receive", ["audio", "hear", "end", "interrupt"], "Audio chunks (the speech, and "
                                                                                   "what the head hears), then end or "
                                                                                   "interrupt."),
            "sendReady": op("send", ["ready"], "The stream is open."),
            "sendFrames": op("send", ["frames", "framesBinary", "ended"], "Frames as they become final, then end."),
            "sendError": op("send", ["error"], "One error, then the close."),
        },
        "components": {"messages": messages},
    }


__all__ = ["document", "start_schema", "ERROR_KINDS"]
