"""``WS /v1/stream``: speech in as it arrives, head motion out as it becomes final.

Protocol (docs/serve.md has examples):

1. The client sends one text message, ``{"type": "start", "model": "stream", "sample_rate": 16000,
   "encoding": "s16le"|"f32le", "seed": 0, "frames": "json"|"binary", "gain": G|[p,y,r],
   "offset": D|[p,y,r] (degrees), "still": false, "amount": 1, "resample": "exact"|"fast",
   "settle": 0, "lookahead_ms": 0}`` (every field but
   ``type`` optional; the controls' ranges are :mod:`headmotion.synthesis`'s; a browser, which
   cannot set headers on a WebSocket, may add ``"api_key"`` — until it is checked the message may
   be at most ``UNAUTHENTICATED_MESSAGE_BYTES``).
2. The server answers ``{"type": "ready", "model", "system", "fps", "latency_ms", ...}``.
3. The client sends binary messages of mono PCM in that encoding — any number of whole samples per
   message, as fast as it likes.  The server resamples them to the model's rate (``exact``: as
   ``POST /v1/motion`` resamples a file, so the frames are the offline answer's) and pushes them
   into the model's stream.
4. Frames come back as soon as they are final: JSON ``{"type": "frames", "first": i, "fps",
   "audio_time", "frames": [{"frame", "time", "rotvec", "pitch_yaw_roll_deg"}, ...]}`` (the records
   of ``headmotion stream``), or binary: a 24-byte header ``<4s I I f d`` = (``b"HMF1"``, first
   frame, frame count, fps, audio seconds received) then per frame six little-endian float32:
   rotation vector (radians) and pitch, yaw, roll (degrees).  Frame ``i`` is at audio time
   ``i / fps``.
5. ``{"type": "end"}`` flushes the tail; the server sends the last frames, then the *settling*
   (``settle`` seconds of frames easing the head to rest plus the offset; none by default),
   ``{"type": "end", "frames": N, "audio_seconds": S}`` and closes (1000).
   ``{"type": "interrupt", "shown": K}`` instead cuts the speech off (the user barged in): the
   frames not yet final are dropped, the head settles from frame ``K - 1`` (the last one the
   client showed; without ``shown``, the last one sent), numbered from ``K``, then the end
   message (``"interrupted": true``) and the close.

The stream is the live core every live path shares (:class:`headmotion.live.core.HeadMotionCore`),
advanced by the worker's one engine (:class:`headmotion.live.engine.LiveEngine`): the decisions due
across all its streams are made together, and each stream's frames are those it gets alone.

Errors: one text message ``{"type": "error", "error": KIND, "detail": SENTENCE}`` (``retry_after``
when the server knows when) then a close with a code (1008 policy: bad start / message / key /
client that reads nothing; 1007 bad audio bytes; 1009 too large or too long; 1013 no free stream
slot or rate limit; 1011 internal).  Back-pressure: outgoing messages wait in a bounded queue
(``queue_messages``); while it is full no more audio is read from the client, so a client that
sends faster than real time is slowed to the pace it reads at and gets every frame; one that lets
nothing go out for ``send_timeout_s`` is closed with ``too_slow``, so a reader that stopped never
grows the server's memory.  A connection counts toward the worker's stream limit from its
handshake, before its key is known.
"""

from __future__ import annotations

import asyncio
import json
import math
import struct
import time
from dataclasses import dataclass

import numpy as np

from ..errors import HeadMotionError
from ..io.resampler import QUALITY
from ..live.core import SETTLE_RANGE_S, FrameBatch, HeadMotionCore, check_seconds
from ..live.engine import LiveEngine
from . import engine
from .access import ApiError, check_rate, identify
from .metrics import log_event

HEADER = struct.Struct("<4sIIfd")
MAGIC = b"HMF1"
ENCODINGS = {"s16le": ("<i2", 32768.0), "f32le": ("<f4", 1.0)}
START_FIELDS = {"type", "model", "sample_rate", "encoding", "seed", "frames", "gain", "offset", "still", "amount", "resample",
                "api_key", "hear", "listening", "settle", "lookahead_ms"}
HEAR_FIELDS = {"sample_rate", "encoding"}
#: ``resample`` → soxr quality (the library's one table, :data:`headmotion.io.resampler.QUALITY`):
#: ``exact`` resamples as ``POST /v1/motion`` does (the stream's frames are the offline answer's;
#: ~20 ms of resampling delay), ``fast`` with less delay (~10 ms) and frames that may differ from
#: the offline answer by a few degrees
RESAMPLE = QUALITY


class ProtocolError(HeadMotionError):
    """A message the protocol does not allow: ``kind``, a sentence and the close code."""

    def __init__(self, kind: str, detail: str, code: int = 1008, extra: dict | None = None):
        super().__init__(detail)
        self.kind, self.detail, self.code, self.extra = kind, detail, code, extra or {}


@dataclass(frozen=True)
class Start:
    model: str | None
    sample_rate: int | None
    encoding: str
    seed: int | None
    frames: str
    controls: engine.Controls
    api_key: str | None
    resample: str = "exact"
    hear_rate: int | None = None  # the other party's audio (hear messages); None: the speech's
    hear_encoding: str = "s16le"
    settle_s: float = 0.0  # seconds of settling after the end or an interruption


def parse_start(text: str | None) -> Start:
    """The first message, checked field by field (ProtocolError ``bad_start`` naming the field)."""
    def bad(detail):
        return ProtocolError("bad_start", detail)

    if text is None:
        raise bad("the first message must be a text JSON object {\"type\": \"start\", ...}; got binary")
    try:
        obj = json.loads(text)
    except (ValueError, RecursionError):
        raise bad("the first message is not JSON; expected {\"type\": \"start\", ...}") from None
    if not isinstance(obj, dict) or obj.get("type") != "start":
        raise bad("the first message must be a JSON object with \"type\": \"start\"")
    unknown = sorted(set(obj) - START_FIELDS)
    if unknown:
        raise bad(f"unknown fields {unknown}; the start message takes {sorted(START_FIELDS)}")
    model = obj.get("model")
    if model is not None and not isinstance(model, str):
        raise bad(f"model must be a name (text); got {model!r:.40}")
    sr = _whole(obj.get("sample_rate"))
    if sr is not None and (isinstance(sr, bool) or not isinstance(sr, int) or not 8000 <= sr <= 192000):
        raise bad(f"sample_rate must be a whole number of Hz between 8000 and 192000; got {sr!r:.40}")
    enc = obj.get("encoding", "s16le")
    if not isinstance(enc, str) or enc not in ENCODINGS:
        raise bad(f"encoding must be one of {sorted(ENCODINGS)}; got {enc!r:.40}")
    seed = _whole(obj.get("seed"))
    try:
        engine.check_seed(seed, allow_none=True)
    except HeadMotionError as exc:
        raise bad(str(exc).replace(" (--seed)", "")) from None
    resample = obj.get("resample", "exact")
    if not isinstance(resample, str) or resample not in RESAMPLE:
        raise bad(f"resample must be one of {sorted(RESAMPLE)}; got {resample!r:.40}")
    frames = obj.get("frames", "json")
    if not isinstance(frames, str) or frames not in ("json", "binary"):
        raise bad(f"frames must be 'json' or 'binary'; got {frames!r:.40}")
    key = obj.get("api_key")
    if key is not None and not isinstance(key, str):
        raise bad("api_key must be text")
    try:
        controls = engine.Controls.parse(gain=_number_or_triple(obj.get("gain"), "gain"),
                                         offset_degrees=_number_or_triple(obj.get("offset"), "offset"),
                                         still=_flag(obj.get("still", False)),
                                         amount=_number(obj.get("amount", 1.0), "amount"),
                                         listening=_number(obj.get("listening", 1.0), "listening"),
                                         lookahead_ms=_number(obj.get("lookahead_ms", 0.0), "lookahead_ms"))
    except HeadMotionError as exc:
        raise bad(str(exc)) from None
    hear_rate, hear_enc = _hear(obj.get("hear"), enc)
    try:
        settle = check_seconds(obj.get("settle", 0.0), SETTLE_RANGE_S, "settle")
    except HeadMotionError as exc:
        raise bad(str(exc)) from None
    return Start(model, sr, enc, seed, frames, controls, key, resample, hear_rate, hear_enc, settle)


def _hear(v, speech_encoding: str) -> tuple[int | None, str]:
    """(rate, encoding) of the hear messages from the start's ``hear`` field (true, null or an object)."""
    if v is None or isinstance(v, bool):
        return None, speech_encoding
    if not isinstance(v, dict) or set(v) - HEAR_FIELDS:
        raise ProtocolError("bad_start", f"hear must be true or an object with {sorted(HEAR_FIELDS)}; got {v!r:.60}")
    sr = _whole(v.get("sample_rate"))
    if sr is not None and (isinstance(sr, bool) or not isinstance(sr, int) or not 8000 <= sr <= 192000):
        raise ProtocolError("bad_start", f"hear.sample_rate must be a whole number of Hz between 8000 and 192000; "
                                         f"got {sr!r:.40}")
    enc = v.get("encoding", speech_encoding)
    if not isinstance(enc, str) or enc not in ENCODINGS:
        raise ProtocolError("bad_start", f"hear.encoding must be one of {sorted(ENCODINGS)}; got {enc!r:.40}")
    return sr, enc


def _number(v, what):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ProtocolError("bad_start", f"{what} must be a number; got {v!r:.40}")
    return v


def _number_or_triple(v, what):
    ok = v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) or (
        isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v))
    if not ok:
        raise ProtocolError("bad_start", f"{what} must be a number or [pitch, yaw, roll]; got {v!r:.40}")
    if v is not None and not all(math.isfinite(x) for x in (v if isinstance(v, list) else [v])):
        raise ProtocolError("bad_start", f"{what} must be finite; got {v!r:.40}")
    return v


def _shown(v, sent: int) -> int | None:
    """An interrupt's ``shown``: a whole number of frames from 0 to those sent (None: all sent)."""
    v = _whole(v)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= sent:
        raise ProtocolError("bad_message", f"interrupt's shown must be a whole number of frames from 0 to the "
                                           f"{sent} sent; got {v!r:.40}")
    return v


def _whole(v):
    """A JSON number without a fraction as an int (``16000.0`` is the integer 16000, as JSON Schema
    counts it); anything else as it is."""
    return int(v) if isinstance(v, float) and v.is_integer() and abs(v) < 2 ** 63 else v


def _flag(v):
    if not isinstance(v, bool):
        raise ProtocolError("bad_start", f"still must be true or false; got {v!r:.40}")
    return v


def decode_chunk(data: bytes, encoding: str) -> np.ndarray:
    """Float32 samples of one binary message (ProtocolError when not whole samples or not finite)."""
    dtype, scale = ENCODINGS[encoding]
    width = np.dtype(dtype).itemsize
    if len(data) % width:
        raise ProtocolError("bad_audio", f"a {encoding} message of {len(data)} bytes is not a whole number of "
                                         f"{width}-byte samples", 1007)
    x = np.frombuffer(data, dtype=dtype).astype(np.float32)
    if scale != 1.0:
        x /= np.float32(scale)
    elif not np.all(np.isfinite(x)):
        raise ProtocolError("bad_audio", "the audio holds NaN or infinite samples", 1007)
    return x


def decode_hear(obj: dict, encoding: str) -> np.ndarray:
    """Float32 samples of a ``{"type": "hear", "audio": BASE64}`` message (ProtocolError
    ``bad_message`` for other fields, ``bad_audio`` for bytes that are not base64 or not whole samples)."""
    import base64
    import binascii

    if set(obj) != {"type", "audio"} or not isinstance(obj.get("audio"), str):
        raise ProtocolError("bad_message", "a hear message is {\"type\": \"hear\", \"audio\": BASE64 PCM}")
    try:
        data = base64.b64decode(obj["audio"], validate=True)
    except (binascii.Error, ValueError):
        raise ProtocolError("bad_audio", "the hear message's audio is not base64", 1007) from None
    return decode_chunk(data, encoding)


def frames_message(rotvec: np.ndarray, fps: float, first: int, audio_time: float, fmt: str):
    """One outgoing message for frames ``first …`` (text for JSON, bytes for binary)."""
    if fmt == "json":
        from ..live.frames import frame_records

        return json.dumps({"type": "frames", "first": first, "fps": fps, "audio_time": round(audio_time, 4),
                           "frames": frame_records(rotvec, fps, first)}, separators=(",", ":"))
    from ..rotations import rotvec_to_pitch_yaw_roll

    rv = np.asarray(rotvec, dtype=np.float64).reshape(-1, 3)
    body = np.hstack([rv, rotvec_to_pitch_yaw_roll(rv, degrees=True)]).astype("<f4")
    return HEADER.pack(MAGIC, first, len(rv), fps, audio_time) + body.tobytes()


def parse_binary_frames(data: bytes) -> tuple[int, float, float, np.ndarray]:
    """(first frame, fps, audio time, ``(n, 6)`` float32) of a binary frames message (for clients)."""
    magic, first, n, fps, audio_time = HEADER.unpack_from(data)
    if magic != MAGIC or len(data) != HEADER.size + 24 * n:
        raise ValueError("not a headmotion binary frames message")
    return first, float(fps), audio_time, np.frombuffer(data, "<f4", offset=HEADER.size).reshape(n, 6)


def live_engine(st) -> LiveEngine:
    """The worker's one engine (:mod:`headmotion.live.engine`): every stream's decisions made
    together."""
    eng = getattr(st, "live_engine", None)
    if eng is None:
        eng = st.live_engine = LiveEngine()
    return eng


class _Closed(Exception):
    pass


#: the first message of a connection whose key is not yet known (no ``Authorization`` header on
#: the handshake) may be this large at most: a start message, not audio
UNAUTHENTICATED_MESSAGE_BYTES = 64 * 1024
#: close codes of the WebSocket layer → the stream's status
_CLOSED_STATUS = {1012: "server_shutdown", 1009: "too_large"}


async def stream_endpoint(websocket) -> None:
    """The ``/v1/stream`` handler: one session per connection."""
    await Session(websocket, websocket.app.state.serve).run()


async def no_such_stream(websocket) -> None:
    """Any other WebSocket path: one error message ``not_found`` and close 1008 (rather than the
    bare 403 a refused handshake gives)."""
    await websocket.accept()
    path = websocket.scope.get("path", "")
    detail = f"no WebSocket at {path[:60]!r}; the stream is /v1/stream"
    websocket.app.state.serve.metrics.errors.labels("not_found").inc()
    try:
        await websocket.send_text(json.dumps({"type": "error", "error": "not_found", "detail": detail}))
        await websocket.close(1008, reason=f"not_found: {detail}"[:120])
    except Exception:  # noqa: BLE001 - the client is gone already
        pass


class Session:
    """One stream connection (see the module docstring)."""

    def __init__(self, ws, st):
        self.ws, self.st, self.lim = ws, st, st.config.limits
        self.key = None
        self.slot = False
        self.pending = False  # admitted, not yet a stream: counts toward the worker's stream limit
        self.queue: asyncio.Queue = asyncio.Queue(maxsize=self.lim.queue_messages)
        self.sender = None
        self.frames = 0
        self.samples_in = 0
        self.t0 = time.perf_counter()
        self.log = {}

    async def run(self) -> None:
        status, reason = "ok", None
        try:
            try:
                self._admit()  # counted from before the handshake completes
            finally:
                await self.ws.accept()
            start = await self._start()
            await self._loop(start)
        except ProtocolError as exc:
            status, reason = exc.kind, exc.detail
            await self._fail(exc)
        except ApiError as exc:
            status, reason = exc.kind, exc.detail
            retry = exc.headers.get("retry-after")
            await self._fail(ProtocolError(exc.kind, exc.detail, 1013 if exc.status in (429, 503) else 1008,
                                           None if retry is None else {"retry_after": int(retry)}))
        except HeadMotionError as exc:  # an unknown model, a model that cannot stream, bad controls
            from .models import UnknownModel

            kind = "unknown_model" if isinstance(exc, UnknownModel) else "bad_start"
            status, reason = kind, str(exc)
            await self._fail(ProtocolError(kind, str(exc)))
        except _Closed as exc:  # 1012: the server shuts down; 1009: a message over the WebSocket layer's limit
            status = _CLOSED_STATUS.get(exc.args[0] if exc.args else None, "client_closed")
            if status == "too_large":
                reason = "a message over the WebSocket size limit (closed by the WebSocket layer)"
        except Exception as exc:  # a bug: the client is told, the server carries on
            status, reason = "internal", f"{type(exc).__name__}: {exc}"[:200]
            await self._fail(ProtocolError("internal", "internal error; the stream was closed", 1011))
        finally:
            await self._release()
            self.st.metrics.requests.labels("/v1/stream", status).inc()
            if status not in ("ok", "client_closed", "server_shutdown"):
                self.st.metrics.errors.labels(status).inc()
            # the worker's engine so far: ticks, decisions, largest tick, pitch reads, ticks with a decision
            eng = getattr(self.st, "live_engine", None)
            log_event("stream", key=None if self.key is None else self.key.name, status=status, reason=reason,
                      frames=self.frames, audio_s=round(self.samples_in / max(1, self.log.get("sr", 1)), 3),
                      wall_s=round(time.perf_counter() - self.t0, 3), **{k: v for k, v in self.log.items() if k != "sr"},
                      engine=None if eng is None else [eng.stats.ticks, eng.stats.decisions, eng.stats.largest,
                                                                 eng.stats.reads, eng.stats.decision_ticks])

    async def _receive(self, timeout: float) -> dict:
        try:
            async with asyncio.timeout(timeout):  # a timer, not a task per message (as wait_for makes)
                msg = await self.ws.receive()
        except TimeoutError:
            raise ProtocolError("idle", f"nothing received for {timeout:g} s; the stream was closed") from None
        if msg["type"] == "websocket.disconnect":
            raise _Closed(msg.get("code"))
        return msg

    def _admit(self) -> None:
        """Refuse a connection past the worker's stream limit (open streams and connections not
        yet started count alike), before anything is read from it."""
        if self.st.slots.load() >= self.lim.max_streams:
            raise ProtocolError("busy", f"this worker carries its limit of {self.lim.max_streams} streams; "
                                        f"try again later", 1013, {"retry_after": 1})
        self.st.slots.enter()
        self.pending = True

    async def _start(self):
        header = dict(self.ws.scope.get("headers") or []).get(b"authorization")
        header = None if header is None else header.decode("latin-1")
        limit_size = (self.ws.scope.get("extensions") or {}).get("headmotion.max_size")
        if header is not None or not self.st.keys.required:
            self.key = identify(self.st, header)  # before anything is read: a stranger learns nothing
        elif limit_size is not None:  # the key will come in the start message: until then, no large messages
            limit_size(UNAUTHENTICATED_MESSAGE_BYTES)
        msg = await self._receive(self.lim.start_timeout_s)
        if self.key is None:  # a browser's key travels in the start message
            text = msg.get("text") if msg.get("bytes") is None else None
            k = None
            if text is not None and len(text) <= UNAUTHENTICATED_MESSAGE_BYTES:
                try:
                    k = json.loads(text).get("api_key")
                except (ValueError, AttributeError, RecursionError):
                    pass
            self.key = identify(self.st, f"Bearer {k}" if isinstance(k, str) else None)
            if limit_size is not None:
                limit_size(None)
        start = parse_start(msg.get("text") if msg.get("bytes") is None else None)
        check_rate(self.st, self.key)
        reg = self.st.registry
        name, model = reg.get(start.model, default=reg.default_stream, streaming=True)
        if not self.st.slots.take(self.key):
            raise ProtocolError("too_many_streams", f"key {self.key.name!r} has its {self.key.streams} concurrent "
                                                    f"streams open", 1013)
        self.slot = True
        self.pending = False
        self.st.slots.leave()
        self.st.metrics.active_streams.inc()
        self.model, self.name, self.start = model, name, start
        self.log = {"model": name, "encoding": start.encoding, "frames_format": start.frames,
                    "sr": start.sample_rate or int(model.sample_rate)}
        return start

    async def _loop(self, start: Start) -> None:
        model = self.model
        model_sr = int(model.sample_rate)
        sr = start.sample_rate or model_sr
        hear_sr = start.hear_rate or sr
        try:
            core = HeadMotionCore(model, seed=start.seed, controls=start.controls, resample=start.resample,
                                  settle_s=start.settle_s, heard_rate=hear_sr)
            core.begin(sr)
        except HeadMotionError as exc:
            raise ProtocolError("bad_start", str(exc)) from None
        fps = core.fps
        eng = live_engine(self.st)
        self.sender = asyncio.create_task(self._send_loop())
        await self._put(json.dumps({"type": "ready", "model": self.name, "system": model.name, "fps": fps,
                                    "latency_ms": core.latency_ms, "sample_rate": sr,
                                    "model_sample_rate": model_sr, "encoding": start.encoding,
                                    "frames": start.frames, "hear": {"sample_rate": hear_sr,
                                                                     "encoding": start.hear_encoding},
                                    "listening": start.controls.listening, "settle": start.settle_s,
                                    "lookahead_ms": start.controls.lookahead_ms}), None)
        max_samples = self.lim.max_stream_seconds * sr
        max_heard = self.lim.max_stream_seconds * hear_sr
        heard = 0
        while True:
            msg = await self._receive(self.lim.idle_timeout_s)
            t_recv = time.perf_counter()
            data = msg.get("bytes")
            if data is not None:
                if len(data) > self.lim.max_message_bytes:
                    raise ProtocolError("too_large", f"a message of {len(data)} bytes; the limit is "
                                                     f"{self.lim.max_message_bytes} bytes", 1009)
                x = decode_chunk(data, start.encoding)
                self.samples_in += len(x)
                if self.samples_in > max_samples:
                    raise ProtocolError("too_long", f"the stream passed its limit of "
                                                    f"{self.lim.max_stream_seconds:g} s of audio", 1009)
                await self._emit(await eng.push(core, x, sr), start.frames, t_recv)
                continue
            text = msg.get("text") or ""
            if len(text) > 2 * self.lim.max_message_bytes:
                raise ProtocolError("too_large", f"a message of {len(text)} characters; the limit is "
                                                 f"{2 * self.lim.max_message_bytes} for a hear message", 1009)
            try:
                obj = json.loads(text)
            except (ValueError, RecursionError):
                obj = None
            kind = obj.get("type") if isinstance(obj, dict) else None
            if kind == "hear":
                y = decode_hear(obj, start.hear_encoding)
                heard += len(y)
                if heard > max_heard:
                    raise ProtocolError("too_long", f"the heard audio passed the stream's limit of "
                                                    f"{self.lim.max_stream_seconds:g} s", 1009)
                core.hear_along(y)
                continue
            if kind == "end" and set(obj) <= {"type"}:
                items = await eng.end(core)
            elif kind == "interrupt" and set(obj) <= {"type", "shown"}:
                items = core.interrupt(shown=_shown(obj.get("shown"), self.frames))
            else:
                raise ProtocolError("bad_message", "after the start message only binary audio, "
                                                   "{\"type\": \"hear\", \"audio\": BASE64}, {\"type\": \"end\"} "
                                                   "and {\"type\": \"interrupt\", \"shown\": K} are accepted")
            for item in items:
                if isinstance(item, FrameBatch):
                    await self._emit(item, start.frames, t_recv)
                else:
                    end = item.message()
                    if item.interrupted:
                        end["interrupted"] = True
                    await self._put(json.dumps(end), None)
            await self._put(None, None)  # close after the queue is sent
            await self.sender
            return

    async def _emit(self, batch: FrameBatch, fmt: str, t_recv: float) -> None:
        n = len(batch)
        if n:
            await self._put(frames_message(batch.rotvec, batch.fps, batch.first, batch.audio_time, fmt), t_recv)
            self.frames = batch.first + n
            self.st.metrics.frames.inc(n)

    async def _put(self, item, t_recv) -> None:
        """Queue one outgoing message.  A full queue holds the stream: no more audio is read from
        the client (TCP passes the pause on to its sender) until a message has gone out; a client
        that lets nothing go out for ``send_timeout_s`` is closed with ``too_slow``."""
        self._check_sender()
        try:
            self.queue.put_nowait((item, t_recv))
        except asyncio.QueueFull:
            pass
        else:
            return
        putter = asyncio.ensure_future(self.queue.put((item, t_recv)))
        done, _ = await asyncio.wait({putter, self.sender}, timeout=self.lim.send_timeout_s,
                                     return_when=asyncio.FIRST_COMPLETED)
        if putter not in done:
            putter.cancel()
            self._check_sender()
            raise ProtocolError("too_slow", f"the client read none of its {self.queue.qsize()} waiting frame "
                                            f"messages in {self.lim.send_timeout_s:g} s; the stream was closed")

    def _check_sender(self) -> None:
        if self.sender is not None and self.sender.done():
            exc = None if self.sender.cancelled() else self.sender.exception()
            raise exc if exc is not None else _Closed()

    async def _send_loop(self) -> None:
        from starlette.websockets import WebSocketDisconnect

        while True:
            item, t_recv = await self.queue.get()
            try:
                if item is None:
                    await self.ws.close(1000)
                    return
                if isinstance(item, bytes):
                    await self.ws.send_bytes(item)
                else:
                    await self.ws.send_text(item)
            except (WebSocketDisconnect, RuntimeError, OSError):
                raise _Closed() from None
            if t_recv is not None:
                self.st.metrics.frame_latency.observe(time.perf_counter() - t_recv)

    async def _stop_sender(self) -> None:
        """Cancel the frame sender and wait until it has stopped."""
        if self.sender is not None and not self.sender.done():
            self.sender.cancel()
            try:
                await self.sender
            except (asyncio.CancelledError, Exception):
                pass

    async def _fail(self, exc: ProtocolError) -> None:
        await self._stop_sender()
        try:  # a client that reads nothing cannot be told; it is left after send_timeout_s
            async with asyncio.timeout(self.lim.send_timeout_s):
                await self.ws.send_text(json.dumps({"type": "error", "error": exc.kind, "detail": exc.detail,
                                                    **exc.extra}))
                await self.ws.close(exc.code, reason=f"{exc.kind}: {exc.detail}"[:120])
        except Exception:  # noqa: BLE001 - the client is gone already, or does not read
            pass

    async def _release(self) -> None:
        await self._stop_sender()
        if self.pending:
            self.pending = False
            self.st.slots.leave()
        if self.slot:
            self.slot = False
            self.st.slots.give(self.key)
            self.st.metrics.active_streams.dec()


__all__ = ["stream_endpoint", "no_such_stream", "parse_start", "decode_chunk", "decode_hear", "frames_message",
           "parse_binary_frames", "ProtocolError", "Start", "HEADER", "MAGIC", "RESAMPLE",
           "UNAUTHENTICATED_MESSAGE_BYTES"]
