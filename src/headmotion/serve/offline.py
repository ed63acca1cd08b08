"""``POST /v1/motion``: speech in, head motion out, as ``headmotion synth`` makes it.

The request body is the speech itself — a wav, flac, ogg or mp3 file (anything the package's
audio loader, :func:`headmotion.io.load_audio`, reads), or raw PCM with ``encoding=s16le|f32le``
and ``sample_rate=HZ`` — and the controls are query parameters (``model``, ``seed``, ``samples``,
``gain``/``gain_pitch``/…, ``offset``/``offset_pitch``/… in degrees, ``still``, ``fps``,
``format``).  The answer is the file ``headmotion synth`` would write, made by the same writer
(:func:`headmotion.io.save_motion`): JSON by default, or BVH, NPZ, CSV, glTF (``gltf`` / ``glb``);
``samples=K`` gives K samples with seeds ``seed … seed+K-1`` — one JSON document
``{"samples": [...]}``, or a zip of ``sample_1.EXT …`` for the other formats.
"""

from __future__ import annotations

import inspect
import io
import json
import tempfile
import time
import zipfile
from pathlib import Path
from typing import Literal, Optional

import numpy as np
from fastapi import APIRouter, Query, Request
from fastapi.responses import Response

from ..errors import AudioLoadingError, ParameterError
from ..synthesis import AMOUNT_RANGE, GAIN_RANGE, LOOKAHEAD_RANGE_MS, OFFSET_RANGE_DEG, SEED_MAX
from ..types import Audio
from . import engine
from .access import ApiError, authorize

router = APIRouter()
_G = f"{GAIN_RANGE[0]:g} to {GAIN_RANGE[1]:g}"
_O = f"{OFFSET_RANGE_DEG[0]:g} to {OFFSET_RANGE_DEG[1]:g}"

#: ``format`` → (file suffix, media type)
FORMATS = {"json": (".json", "application/json"), "bvh": (".bvh", "text/plain; charset=utf-8"),
           "npz": (".npz", "application/octet-stream"), "csv": (".csv", "text/csv; charset=utf-8"),
           "gltf": (".gltf", "model/gltf+json"), "glb": (".glb", "model/gltf-binary")}
#: content types of speech files → a suffix the audio loader recognises
AUDIO_TYPES = {"audio/wav": ".wav", "audio/x-wav": ".wav", "audio/wave": ".wav", "audio/vnd.wave": ".wav",
               "audio/flac": ".flac", "audio/x-flac": ".flac", "audio/ogg": ".ogg", "audio/mpeg": ".mp3",
               "audio/mp3": ".mp3", "application/octet-stream": ".audio"}
PCM = {"s16le": ("<i2", 32768.0), "f32le": ("<f4", 1.0)}


async def read_body(request: Request, limit: int) -> bytes:
    """The request body, refused with 413 past ``limit`` bytes (by Content-Length or as it streams)."""
    length = request.headers.get("content-length")
    if length is not None and length.isdigit() and int(length) > limit:
        raise ApiError(413, "too_large", f"request body of {length} bytes; the limit is {limit} bytes")
    chunks, seen = [], 0
    async for chunk in request.stream():
        seen += len(chunk)
        if seen > limit:
            raise ApiError(413, "too_large", f"request body larger than the limit of {limit} bytes")
        chunks.append(chunk)
    body = b"".join(chunks)
    if not body:
        raise ApiError(400, "bad_audio", "empty request body; send the speech file (or raw PCM) as the body")
    return body


#: Content-Types that say nothing about the body (absent, or what ``curl --data-binary`` sends by
#: default): the container is recognised from its first bytes instead
SNIFFED_TYPES = frozenset({"", "application/x-www-form-urlencoded"})
_MAGIC = ((b"RIFF", ".wav"), (b"fLaC", ".flac"), (b"OggS", ".ogg"), (b"ID3", ".mp3"), (b"\xff\xfb", ".mp3"),
          (b"\xff\xf3", ".mp3"), (b"\xff\xf2", ".mp3"))


def sniff_container(body: bytes) -> str | None:
    """The file suffix of a speech file from its first bytes (WAV, FLAC, Ogg, MP3), or None."""
    return next((suffix for magic, suffix in _MAGIC if body.startswith(magic)), None)


def decode_audio(body: bytes, content_type: str, encoding: str | None, sample_rate: int | None) -> Audio:
    """The speech of a request body: raw PCM when ``encoding`` is given, else a file."""
    if encoding is not None:
        if encoding not in PCM:
            raise ApiError(400, "bad_parameter", f"encoding must be one of {sorted(PCM)}; got {encoding!r}")
        if sample_rate is None or not 8000 <= sample_rate <= 192000:
            raise ApiError(400, "bad_parameter", f"raw PCM needs sample_rate between 8000 and 192000 Hz; "
                                                 f"got {sample_rate}")
        dtype, scale = PCM[encoding]
        width = np.dtype(dtype).itemsize
        if len(body) % width:
            raise ApiError(400, "bad_audio", f"{encoding} body of {len(body)} bytes is not a whole number of "
                                             f"{width}-byte samples")
        x = np.frombuffer(body, dtype=dtype).astype(np.float32) / np.float32(scale)
        if not np.all(np.isfinite(x)):
            raise ApiError(400, "bad_audio", "the PCM holds NaN or infinite samples")
        return Audio(x, int(sample_rate))
    ctype = content_type.split(";", 1)[0].strip().lower()
    suffix = AUDIO_TYPES.get(ctype)
    if suffix is None and ctype in SNIFFED_TYPES:  # no type, or curl's default: read the file's own header
        suffix = sniff_container(body)
    if suffix is None:
        raise ApiError(415, "bad_audio", f"Content-Type {ctype or '(none)'!r} is not speech; send "
                                         f"{sorted(AUDIO_TYPES)} or raw PCM with encoding= and sample_rate=")
    from ..io import load_audio

    with tempfile.TemporaryDirectory(prefix="headmotion-serve-") as tmp:
        path = Path(tmp) / f"speech{suffix}"
        path.write_bytes(body)
        try:
            return load_audio(path)
        except AudioLoadingError as exc:
            raise ApiError(400, "bad_audio", str(exc).replace(str(path), "the request body")) from None


def encode_motions(motions, fmt: str) -> tuple[bytes, str]:
    """The bytes of ``motions`` in ``fmt`` (one file; several as JSON ``samples`` or a zip)."""
    from ..io import save_motion

    suffix, media = FORMATS[fmt]
    with tempfile.TemporaryDirectory(prefix="headmotion-serve-") as tmp:
        blobs = []
        for k, m in enumerate(motions, start=1):
            path = Path(tmp) / f"sample_{k}{suffix}"
            save_motion(m, path, format="gltf" if fmt == "glb" else fmt)
            blobs.append((path.name, path.read_bytes()))
    if len(blobs) == 1:
        return blobs[0][1], media
    if fmt == "json":
        docs = [json.loads(b) for _, b in blobs]
        return json.dumps({"samples": docs}, separators=(",", ":")).encode(), media
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, b in blobs:
            z.writestr(name, b)
    return buf.getvalue(), "application/zip"


@router.post("/v1/motion", tags=["motion"], summary="Head motion for a speech file",
             response_class=Response,
             responses={200: {"description": "The motion file (JSON by default)"},
                        400: {"description": "Bad audio or parameter"}, 401: {"description": "No or bad key"},
                        413: {"description": "Body or speech too long"}, 429: {"description": "Rate limit"}},
             openapi_extra={"requestBody": {"required": True, "content": {
                 t: {"schema": {"type": "string", "format": "binary"}} for t in
                 ("audio/wav", "audio/flac", "audio/ogg", "audio/mpeg", "application/octet-stream")}}})
async def motion(
    request: Request,
    model: Optional[str] = Query(None, description="Model name (GET /v1/models); default 'default'."),
    seed: Optional[int] = Query(None, description=f"Synthesis seed, 0 to {SEED_MAX}; sample k uses seed + k "
                                                  "(default: the model's own, 0 for the shipped models)."),
    samples: int = Query(1, ge=1, le=engine.MAX_SAMPLES, description="Number of samples."),
    amount: Optional[float] = Query(None, description=f"How much the head moves, {AMOUNT_RANGE[0]:g} to "
                                    f"{AMOUNT_RANGE[1]:g}: 1 natural (default), 2 animated, 0.5 calm, 0 still; "
                                    "by the choice of recorded movements (motion-matching models)."),
    gain: Optional[str] = Query(None, description=f"Amplitude about the mean pose, {_G} on each axis: G or P,Y,R."),
    gain_pitch: Optional[float] = Query(None, description=f"Pitch amplitude, {_G}."),
    gain_yaw: Optional[float] = Query(None, description=f"Yaw amplitude, {_G}."),
    gain_roll: Optional[float] = Query(None, description=f"Roll amplitude, {_G}."),
    offset: Optional[str] = Query(None, description=f"Degrees added after the gain, {_O} on each axis: D or P,Y,R."),
    offset_pitch: Optional[float] = Query(None, description=f"Degrees added to pitch, {_O}."),
    offset_yaw: Optional[float] = Query(None, description=f"Degrees added to yaw, {_O}."),
    offset_roll: Optional[float] = Query(None, description=f"Degrees added to roll, {_O}."),
    still: bool = Query(False, description="A head that does not move (rest pose plus offset)."),
    lookahead_ms: Optional[float] = Query(None, description=f"A live model (stream): read the speech this many ms "
                                          f"ahead, {LOOKAHEAD_RANGE_MS[0]:g} to {LOOKAHEAD_RANGE_MS[1]:g} "
                                          "(the frames of WS /v1/stream with the same lookahead_ms); default 0."),
    fps: Optional[float] = Query(None, description=f"Output frame rate, {engine.FPS_RANGE[0]:g} to "
                                                   f"{engine.FPS_RANGE[1]:g} (default: the model's)."),
    format: Literal["json", "bvh", "npz", "csv", "gltf", "glb"] = Query("json"),
    encoding: Optional[Literal["s16le", "f32le"]] = Query(None, description="Raw PCM body: its encoding."),
    sample_rate: Optional[int] = Query(None, description="Raw PCM body: its sample rate (Hz)."),
):
    st = request.app.state.serve
    authorize(request, st)
    t0 = time.perf_counter()
    check_query(request, QUERY)
    try:
        controls = engine.Controls.parse(gain=gain, offset_degrees=offset, gain_pyr=(gain_pitch, gain_yaw, gain_roll),
                                         offset_pyr_degrees=(offset_pitch, offset_yaw, offset_roll), still=still, fps=fps,
                                         amount=amount, lookahead_ms=0.0 if lookahead_ms is None else lookahead_ms)
        engine.check_seed(seed, samples, allow_none=True)
    except ParameterError as exc:
        raise ApiError(400, "bad_parameter", str(exc)) from None
    name, m = st.registry.get(model, default=engine.DEFAULT_OFFLINE)
    body = await read_body(request, st.config.limits.max_body_bytes)
    limit_s = st.config.limits.max_audio_seconds

    def work():
        audio = decode_audio(body, request.headers.get("content-type", ""), encoding, sample_rate)
        if audio.duration > limit_s:
            raise ApiError(413, "too_long", f"{audio.duration:.1f} s of speech; the limit is {limit_s:g} s")
        motions = engine.synthesize(m, audio, seed=seed, samples=samples, controls=controls)
        return audio.duration, *encode_motions(motions, format)

    from starlette.concurrency import run_in_threadpool

    duration, data, media = await run_in_threadpool(work)
    dt = time.perf_counter() - t0
    st.metrics.offline_seconds.observe(dt)
    request.state.log = {"model": name, "audio_s": round(duration, 3), "format": format,
                         "samples": samples, "synth_s": round(dt, 4)}
    suffix = FORMATS[format][0] if samples == 1 or format == "json" else ".zip"
    return Response(data, media_type=media, headers={
        "content-disposition": f'attachment; filename="motion{suffix}"', "x-headmotion-model": name})


def check_query(request: Request, known) -> None:
    """400 ``bad_parameter`` naming any query parameter the route does not take (a misspelt
    control is refused rather than ignored)."""
    unknown = sorted(set(request.query_params) - set(known))
    if unknown:
        raise ApiError(400, "bad_parameter", f"unknown query parameter{'s' if len(unknown) > 1 else ''} "
                                             f"{', '.join(repr(u[:40]) for u in unknown[:5])}; "
                                             f"this route takes {sorted(known)}")


#: the query parameters of ``POST /v1/motion`` (the arguments of :func:`motion` but the request)
QUERY = tuple(p for p in inspect.signature(motion).parameters if p != "request")

__all__ = ["router", "check_query", "QUERY", "decode_audio", "encode_motions", "read_body", "FORMATS"]
