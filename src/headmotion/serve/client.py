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

import json
from dataclasses import dataclass
from pathlib import Path
from typing import AsyncIterable, AsyncIterator, Iterable

import numpy as np

from ..errors import HeadMotionError

_TYPES = {".wav": "audio/wav", ".flac": "audio/flac", ".ogg": "audio/ogg", ".mp3": "audio/mpeg"}


class ServerError(HeadMotionError):
    """The server refused a request or closed a stream with an error: ``kind`` and its sentence."""

    def __init__(self, kind: str, detail: str, status: int | None = None):
        super().__init__(f"{kind}: {detail}")
        self.kind, self.detail, self.status = kind, detail, status


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


def _pcm(chunk, encoding: str) -> bytes:
    if isinstance(chunk, (bytes, bytearray, memoryview)):
        return bytes(chunk)
    x = np.asarray(chunk, dtype=np.float32).reshape(-1)
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
            try:
                d = r.json()
                raise ServerError(d.get("error", "error"), d.get("detail", r.text), r.status_code)
            except ValueError:
                raise ServerError("http", f"{r.status_code}: {r.text[:200]}", r.status_code) from None
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
                     model: str | None = None, seed: int = 0, frames: str = "binary", **controls) -> AsyncIterator[Frames]:
        """Stream ``chunks`` (float32 arrays or PCM bytes, any size) and yield :class:`Frames` as
        the server makes them final; the tail after the last chunk.  Raises ServerError on an error."""
        import asyncio

        import websockets

        from .stream import parse_binary_frames

        url = self.base_url.replace("http://", "ws://", 1).replace("https://", "wss://", 1) + "/v1/stream"
        start = {"type": "start", "sample_rate": sample_rate, "encoding": encoding, "seed": seed, "frames": frames,
                 **({"model": model} if model else {}), **{k: v for k, v in controls.items() if v is not None}}
        async with websockets.connect(url, additional_headers=self._headers(), max_size=None) as ws:
            await ws.send(json.dumps(start))
            ready = json.loads(await ws.recv())
            if ready.get("type") == "error":
                raise ServerError(ready["error"], ready["detail"])

            async def feed():
                if hasattr(chunks, "__aiter__"):
                    async for c in chunks:
                        await ws.send(_pcm(c, encoding))
                else:
                    for c in chunks:
                        await ws.send(_pcm(c, encoding))
                await ws.send(json.dumps({"type": "end"}))

            sender = asyncio.create_task(feed())
            try:
                async for msg in ws:
                    if isinstance(msg, bytes):
                        first, fps, t, a = parse_binary_frames(msg)
                        yield Frames(first, fps, t, a[:, :3].astype(np.float64), a[:, 3:].astype(np.float64))
                        continue
                    d = json.loads(msg)
                    if d["type"] == "frames":
                        rv = np.array([f["rotvec"] for f in d["frames"]], dtype=np.float64)
                        pyr = np.array([f["pitch_yaw_roll_deg"] for f in d["frames"]], dtype=np.float64)
                        yield Frames(d["first"], d["fps"], d["audio_time"], rv, pyr)
                    elif d["type"] == "error":
                        raise ServerError(d["error"], d["detail"])
                    elif d["type"] == "end":
                        break
            finally:
                if not sender.done():
                    sender.cancel()
                await asyncio.gather(sender, return_exceptions=True)  # a refused send shows as the error above


__all__ = ["Client", "Frames", "ServerError"]
