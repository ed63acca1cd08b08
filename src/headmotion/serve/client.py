"""A small Python client of ``headmotion serve``: offline calls with httpx and streams with
websockets (the ``live`` / ``test`` extras)::

    from headmotion.serve.client import Client

    client = Client("http://localhost:8000", api_key=None)
    bvh = client.motion("speech.wav", format="bvh", seed=3)          # bytes of the file
    motion = client.motion_json("speech.wav")                          # a Motion

    async for frames in client.stream(chunks, sample_rate=16000):     # chunks: float32 arrays
        print(frames.first, frames.rotvec.shape)                       # frames as they are final

docs/serve.md describes the protocol the client speaks.
"""

from __future__ import annotations

import collections
import json
from dataclasses import dataclass
from pathlib import Path
from typing import AsyncIterable, AsyncIterator, Iterable

import numpy as np

from ..errors import HeadMotionError, ParameterError

_TYPES = {".wav": "audio/wav", ".flac": "audio/flac", ".ogg": "audio/ogg", ".mp3": "audio/mpeg"}


#: a 2-D chunk is ``(samples, channels)`` (as soundfile reads a file) with at most this many channels
MAX_CHANNELS = 8
#: waits (s) before each reconnection after the server restarts (close 1012)
RECONNECT_WAITS = (0.5, 1.0, 2.0, 4.0)


class ServerError(HeadMotionError):
    """The server refused a request or closed a stream with an error: ``kind`` and its sentence,
    the HTTP ``status`` (offline calls) and ``retry_after`` seconds when the server said when to
    try again (``rate_limited``, ``busy``)."""

    def __init__(self, kind: str, detail: str, status: int | None = None, retry_after: float | None = None):
        super().__init__(f"{kind}: {detail}")
        self.kind, self.detail, self.status, self.retry_after = kind, detail, status, retry_after


@dataclass(frozen=True)
class Frames:
    """A batch of final frames: ``first`` frame number, ``fps``, audio seconds the server had when it
    sent them, rotation vectors ``(n, 3)`` radians and pitch/yaw/roll ``(n, 3)`` degrees."""

    first: int
    fps: float
    audio_time: float
    rotvec: np.ndarray
    pitch_yaw_roll_deg: np.ndarray

    @property
    def times(self) -> np.ndarray:
        """Audio time of each frame (s)."""
        return (self.first + np.arange(len(self.rotvec))) / self.fps


def mono(chunk) -> np.ndarray:
    """A chunk of samples as mono float32: 1-D as it is; 2-D ``(samples, channels)`` — what
    ``soundfile.read`` gives for a stereo file — mixed down to the mean of its channels (never
    interleaved into a mono stream of twice the length).  Anything else is refused
    (:class:`~headmotion.errors.ParameterError`), a channels-first array too."""
    x = np.asarray(chunk, dtype=np.float32)
    if x.ndim <= 1:
        return x.reshape(-1)
    if x.ndim == 2 and 1 <= x.shape[1] <= MAX_CHANNELS:
        return x.mean(axis=1, dtype=np.float32) if x.shape[1] > 1 else x[:, 0]
    raise ParameterError(f"audio chunks must be 1-D samples or 2-D (samples, channels) with at most "
                         f"{MAX_CHANNELS} channels; got shape {x.shape} (transpose a channels-first array)")


def _pcm(chunk, encoding: str) -> bytes:
    if isinstance(chunk, (bytes, bytearray, memoryview)):
        return bytes(chunk)
    x = mono(chunk)
    if encoding == "s16le":
        return (np.clip(x, -1, 1) * 32767).astype("<i2").tobytes()
    return x.astype("<f4").tobytes()


class Client:
    """Calls one server; ``api_key`` goes in ``Authorization: Bearer`` (never in a URL)."""

    def __init__(self, base_url: str = "http://127.0.0.1:8000", *, api_key: str | None = None, timeout: float = 120.0):
        self.base_url, self.api_key, self.timeout = base_url.rstrip("/"), api_key, timeout

    def _headers(self) -> dict:
        return {} if self.api_key is None else {"authorization": f"Bearer {self.api_key}"}

    def _check(self, r):
        if r.status_code >= 400:
            retry = r.headers.get("retry-after")
            retry = float(retry) if retry is not None and retry.isdigit() else None
            try:
                d = r.json()
            except ValueError:
                raise ServerError("http", f"{r.status_code}: {r.text[:200]}", r.status_code, retry) from None
            raise ServerError(d.get("error", "error"), d.get("detail", r.text), r.status_code, retry)
        return r

    def models(self) -> list[dict]:
        """The server's model cards."""
        import httpx

        r = httpx.get(f"{self.base_url}/v1/models", headers=self._headers(), timeout=self.timeout)
        return self._check(r).json()["models"]

    def motion(self, speech, *, format: str = "json", sample_rate: int | None = None,
               encoding: str | None = None, **controls) -> bytes:
        """The motion file for ``speech`` (a path, or raw PCM bytes with ``encoding`` and
        ``sample_rate``); ``controls``: model, seed, samples, gain, gain_pitch…, offset (degrees),
        offset_pitch…, still, fps — as in ``headmotion synth``."""
        import httpx

        params = {k: (",".join(str(v) for v in val) if isinstance(val, (tuple, list)) else val)
                  for k, val in controls.items() if val is not None}
        params["format"] = format
        if isinstance(speech, (bytes, bytearray)):
            body, ctype = bytes(speech), "application/octet-stream"
            if encoding is not None:
                params.update(encoding=encoding, sample_rate=sample_rate)
        else:
            p = Path(speech)
            body, ctype = p.read_bytes(), _TYPES.get(p.suffix.lower(), "application/octet-stream")
        r = httpx.post(f"{self.base_url}/v1/motion", params=params, content=body,
                       headers={**self._headers(), "content-type": ctype}, timeout=self.timeout)
        return self._check(r).content

    def motion_json(self, speech, **controls):
        """:meth:`motion` in JSON, read back as a :class:`~headmotion.types.Motion`."""
        import tempfile

        from ..io import load_motion

        data = self.motion(speech, format="json", **controls)
        with tempfile.TemporaryDirectory() as tmp:
            p = Path(tmp) / "motion.json"
            p.write_bytes(data)
            return load_motion(p)

    async def stream(self, chunks: AsyncIterable | Iterable, *, sample_rate: int = 16000, encoding: str = "f32le",
                     model: str | None = None, seed: int = 0, frames: str = "binary", reconnect: int = 3,
                     **controls) -> AsyncIterator[Frames]:
        """Stream ``chunks`` and yield :class:`Frames` as the server makes them final; the tail
        after the last chunk.

        Parameters
        ----------
        chunks : (async) iterable of float arrays or PCM bytes, any size
            Float chunks are 1-D mono or 2-D ``(samples, channels)``, mixed down to mono
            (:func:`mono`); bytes are sent as they are (mono PCM in ``encoding``).
        reconnect : int
            When the server restarts (close 1012), reconnect up to this many times (waiting
            :data:`RECONNECT_WAITS`) and go on on a new stream from the first chunk the server
            had not confirmed (each frames message says how much audio it had).  Frames are
            numbered on in the whole stream; those of the last ~lookahead of audio before the
            restart are missing (the new stream starts without that context).
        **controls
            Fields of the start message: ``gain``, ``offset``, ``still``, ``amount``, ``resample``,
            ``settle``, ``lookahead_ms`` (a live model reads the speech that far ahead; its frames
            come that much later) … (docs/serve.md).

        Raises :class:`ServerError` on an error (its ``retry_after`` set when the server gave one)."""
        import asyncio

        source: asyncio.Queue = asyncio.Queue(maxsize=16)  # the chunks, read once for every reconnection
        pump = asyncio.create_task(_pump(chunks, source))
        # samples sent so far; the chunks the server has not confirmed (start sample, bytes), sent
        # again on a new stream; whether the source is done; the next frame number to yield
        state = {"sent": 0, "unconfirmed": collections.deque(), "ended": False, "next": 0}
        attempt = 0
        try:
            while True:
                try:
                    async for f in self._one_stream(source, state, sample_rate=sample_rate, encoding=encoding,
                                                    model=model, seed=seed, frames=frames, **controls):
                        yield f
                    return
                except _Restart:
                    if attempt >= reconnect:
                        raise ServerError("server_restart", f"the server restarted (close 1012) {attempt + 1} "
                                                            f"times; gave up") from None
                    await asyncio.sleep(RECONNECT_WAITS[min(attempt, len(RECONNECT_WAITS) - 1)])
                    attempt += 1
        finally:
            pump.cancel()
            await asyncio.gather(pump, return_exceptions=True)

    async def _one_stream(self, source, state, *, sample_rate, encoding, model, seed, frames, **controls):
        import asyncio

        import websockets

        from .stream import parse_binary_frames

        url = self.base_url.replace("http://", "ws://", 1).replace("https://", "wss://", 1) + "/v1/stream"
        start = {"type": "start", "sample_rate": sample_rate, "encoding": encoding, "seed": seed, "frames": frames,
                 **({"model": model} if model else {}), **{k: v for k, v in controls.items() if v is not None}}
        resumed = state["sent"] > 0
        try:
            ws = await websockets.connect(url, additional_headers=self._headers(), max_size=None)
        except OSError:
            if resumed:  # the server is coming back up
                raise _Restart() from None
            raise
        unconfirmed = state["unconfirmed"]
        origin = unconfirmed[0][0] if unconfirmed else state["sent"]  # this stream's sample 0
        width = 2 if encoding == "s16le" else 4
        try:
            await ws.send(json.dumps(start))
            ready = json.loads(await ws.recv())
            if ready.get("type") == "error":
                raise _error(ready)
            base = int(round(origin / sample_rate * ready["fps"]))  # this stream's frame 0 in the whole stream

            async def feed():
                try:
                    for _, data in list(unconfirmed):  # what the last stream may not have had
                        await ws.send(data)
                    while not state["ended"]:
                        c = await source.get()
                        if c is _END:
                            state["ended"] = True
                            break
                        if isinstance(c, BaseException):
                            raise c
                        data = _pcm(c, encoding)
                        unconfirmed.append((state["sent"], data))
                        state["sent"] += len(data) // width
                        await ws.send(data)
                    await ws.send(json.dumps({"type": "end"}))
                except websockets.ConnectionClosed:
                    pass  # the reader sees why
                except Exception as exc:  # noqa: BLE001 - a bad chunk or a failing source: told to the caller
                    state["error"] = exc
                    await ws.close()

            def batch(first, fps, t, rv, pyr):
                """The frames not yielded yet, numbered in the whole stream; the audio confirmed."""
                confirmed = origin + int(round(t * sample_rate))
                while unconfirmed and unconfirmed[0][0] + len(unconfirmed[0][1]) // width <= confirmed:
                    unconfirmed.popleft()
                first += base
                skip = max(0, state["next"] - first)
                if skip >= len(rv):
                    return None
                state["next"] = first + len(rv)
                return Frames(first + skip, fps, t + origin / sample_rate, rv[skip:], pyr[skip:])

            sender = asyncio.create_task(feed())
            try:
                async for msg in ws:
                    if isinstance(msg, bytes):
                        first, fps, t, a = parse_binary_frames(msg)
                        f = batch(first, fps, t, a[:, :3].astype(np.float64), a[:, 3:].astype(np.float64))
                    else:
                        d = json.loads(msg)
                        if d["type"] == "error":
                            raise _error(d)
                        if d["type"] == "end":
                            return
                        if d["type"] != "frames":
                            continue
                        f = batch(d["first"], d["fps"], d["audio_time"],
                                  np.array([r["rotvec"] for r in d["frames"]], dtype=np.float64),
                                  np.array([r["pitch_yaw_roll_deg"] for r in d["frames"]], dtype=np.float64))
                    if f is not None:
                        yield f
            finally:
                if not sender.done():
                    sender.cancel()
                await asyncio.gather(sender, return_exceptions=True)
            if "error" in state:
                raise state.pop("error")
        except websockets.ConnectionClosedError as exc:
            if exc.rcvd is not None and exc.rcvd.code == 1012:
                raise _Restart() from None
            if "error" in state:
                raise state.pop("error") from None
            raise ServerError("closed", f"the connection closed ({exc})") from None
        finally:
            await ws.close()


_END = object()


async def _pump(chunks, queue) -> None:
    """Every chunk of ``chunks`` (sync or async) into ``queue``, then :data:`_END` (or the
    exception the source raised)."""
    try:
        if hasattr(chunks, "__aiter__"):
            async for c in chunks:
                await queue.put(c)
        else:
            for c in chunks:
                await queue.put(c)
    except Exception as exc:  # noqa: BLE001 - handed to the stream, which raises it
        await queue.put(exc)
        return
    await queue.put(_END)


class _Restart(Exception):
    """The server closed the stream with 1012 (restart)."""


def _error(d: dict) -> ServerError:
    return ServerError(d.get("error", "error"), d.get("detail", ""), retry_after=d.get("retry_after"))


__all__ = ["Client", "Frames", "ServerError", "mono", "MAX_CHANNELS", "RECONNECT_WAITS"]
