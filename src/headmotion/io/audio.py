"""Reading and writing speech audio (thesis §3.4: audio aligned to the motion, 16 kHz for features).

:func:`load_audio` returns a mono :class:`~headmotion.types.Audio`:

* wav / flac / ogg (and anything else libsndfile reads) via **soundfile**;
* mp3 and the audio track of video containers (mp4, mkv, mov, mpg, webm, …) via **PyAV**
  (FFmpeg's decoders); a file named ``.wav`` whose content soundfile cannot decode (for example
  MP3 data in a ``.wav``) is handed to PyAV as well;
* several channels are downmixed to mono by averaging them (the original channel count is logged
  at DEBUG level and returned by :func:`audio_info`);
* with ``sample_rate=`` the signal is resampled with **soxr** (high quality).

Libraries considered: soundfile (libsndfile) for PCM / float / FLAC / Ogg, PyAV for compressed and
container formats (audioread and pydub were considered: both shell out or wrap the same FFmpeg),
soxr for resampling (faster and better than ``scipy.signal.resample_poly`` at the same quality).

Every failure is an :class:`~headmotion.errors.AudioLoadingError` naming the file and what was
expected: missing file, empty file, truncated wav, bytes that are not audio, zero-length audio,
NaN/inf samples, a video without an audio track.
"""

from __future__ import annotations

import logging
import struct
from pathlib import Path

import numpy as np

from ..errors import AudioLoadingError, ParameterError
from ..types import Audio
from ._limits import SAMPLE_RATE_RANGE
from .atomic import atomic_path

log = logging.getLogger(__name__)

#: Extensions decoded with PyAV directly (soundfile is tried first for everything else).
PYAV_EXTENSIONS = frozenset(
    {".mp3", ".mp4", ".m4a", ".aac", ".mkv", ".mka", ".webm", ".mov", ".avi", ".mpg", ".mpeg",
     ".ts", ".m2ts", ".flv", ".wma", ".wmv", ".opus", ".3gp", ".amr", ".ac3"}
)

_SAVE_SUBTYPE = {".wav": "PCM_16", ".flac": "PCM_16", ".ogg": "VORBIS", ".aiff": "PCM_16",
                 ".aif": "PCM_16"}


def _check_file(path: Path) -> None:
    if not path.exists():
        raise AudioLoadingError(f"{path}: file not found; expected an audio or video file")
    if path.is_dir():
        raise AudioLoadingError(f"{path}: is a directory; expected an audio or video file")
    if path.stat().st_size == 0:
        raise AudioLoadingError(f"{path}: empty file (0 bytes); expected an audio or video file")


def _check_riff_wav(path: Path) -> None:
    """Raise when a RIFF/WAVE file's ``data`` chunk claims more bytes than the file holds.

    libsndfile silently reads what is there, so a file cut off during copying would otherwise load
    as shorter audio without any notice."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(12)
        if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
            return
        pos = 12
        while pos + 8 <= size:
            fh.seek(pos)
            chunk = fh.read(8)
            if len(chunk) < 8:
                break
            cid, csize = chunk[:4], struct.unpack("<I", chunk[4:])[0]
            if cid == b"fmt ":
                fmt = fh.read(min(csize, 16))
                if len(fmt) < 16:
                    raise AudioLoadingError(f"{path}: damaged wav header: the fmt chunk holds {len(fmt)} "
                                            f"bytes; expected at least 16")
                _tag, channels, rate, _brate, _align, bits = struct.unpack("<HHIIHH", fmt)
                if not 1 <= channels <= 256:
                    raise AudioLoadingError(f"{path}: damaged wav header: {channels} channels; expected 1–256")
                _check_rate(path, rate, "the wav header's sample rate")
                if bits == 0 or bits > 64:
                    raise AudioLoadingError(f"{path}: damaged wav header: {bits} bits per sample; "
                                            f"expected 8–64")
            if cid == b"data":
                if csize != 0xFFFFFFFF and pos + 8 + csize > size:
                    have = size - pos - 8
                    raise AudioLoadingError(
                        f"{path}: truncated wav: the data chunk declares {csize} bytes but only "
                        f"{have} are present; expected a complete file"
                    )
                return
            pos += 8 + csize + (csize & 1)
        # no data chunk found: libsndfile will complain with its own message


def _finish(path: Path, data: np.ndarray, sr: int, channels: int, sample_rate: int | None,
            decoder: str) -> Audio:
    """Downmix ``data`` (n, channels) to mono, check it, resample."""
    if data.ndim == 2:
        mono = data.mean(axis=1, dtype=np.float64) if data.shape[1] > 1 else data[:, 0]
    else:
        mono = data
    mono = np.asarray(mono, dtype=np.float32)
    if mono.size == 0:
        raise AudioLoadingError(f"{path}: zero-length audio (0 samples); expected speech")
    if not np.all(np.isfinite(mono)):
        bad = int(np.count_nonzero(~np.isfinite(mono)))
        raise AudioLoadingError(
            f"{path}: {bad} of {mono.size} samples are NaN or inf; expected finite audio samples"
        )
    if channels > 1:
        log.debug("%s: downmixed %d channels to mono (%s)", path, channels, decoder)
    _check_rate(path, sr, "sample rate")
    if sample_rate is not None and int(sample_rate) != sr:
        mono = resample(mono, sr, int(sample_rate))
        sr = int(sample_rate)
    return Audio(mono, sr)


def _check_rate(path, sr, what: str) -> int:
    lo, hi = SAMPLE_RATE_RANGE
    try:
        ok = lo <= int(sr) <= hi
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise AudioLoadingError(f"{path}: {what} {sr!r} Hz; expected {lo}–{hi} Hz (damaged header?)")
    return int(sr)


def resample(samples: np.ndarray, in_rate: int, out_rate: int) -> np.ndarray:
    """Resample a mono float signal with soxr (``HQ`` quality).

    Parameters
    ----------
    samples : np.ndarray [shape=(n,)]
    in_rate, out_rate : int, Hz

    Returns
    -------
    np.ndarray [shape=(≈ n * out_rate / in_rate,), dtype=float32]
    """
    import soxr

    if in_rate <= 0 or out_rate <= 0:
        raise ParameterError(f"sample rates must be positive; got {in_rate} -> {out_rate}")
    x = np.asarray(samples, dtype=np.float32)
    if in_rate == out_rate or x.size == 0:
        return x.copy()
    return np.asarray(soxr.resample(x, in_rate, out_rate, quality="HQ"), dtype=np.float32)


def _read_soundfile(path: Path):
    import soundfile as sf

    with sf.SoundFile(str(path)) as f:
        sr, ch = f.samplerate, f.channels
        data = f.read(dtype="float32", always_2d=True)
    return data, sr, ch


def _read_pyav(path: Path):
    """Decode the first audio stream with PyAV; returns (data (n, ch) float32, sr, channels)."""
    try:
        import av
    except ImportError as exc:  # pragma: no cover - av is a hard dependency
        from ..errors import MissingDependencyError

        raise MissingDependencyError("PyAV (`pip install av`) is needed to decode this file") from exc
    try:
        container = av.open(str(path))
    except Exception as exc:  # av.error.InvalidDataError etc.
        raise AudioLoadingError(
            f"{path}: not a readable audio or video file ({exc}); expected wav/flac/ogg/mp3 or a "
            "video container with an audio track"
        ) from None
    with container:
        streams = container.streams.audio
        if len(streams) == 0:
            kinds = ", ".join(sorted({s.type for s in container.streams})) or "no streams"
            raise AudioLoadingError(
                f"{path}: the file has no audio track (it holds {kinds}); expected a file with sound"
            )
        stream = streams[0]
        try:
            ctx = stream.codec_context
            sr = int(getattr(ctx, "sample_rate", 0) or stream.rate or 0)
            channels = int(getattr(ctx, "channels", 0) or 1)
            _check_rate(path, sr, "the audio track's sample rate")
            resampler = av.AudioResampler(format="fltp", layout=ctx.layout, rate=sr)
        except AudioLoadingError:
            raise
        except Exception as exc:  # a damaged header leaves PyAV without a codec context
            raise AudioLoadingError(f"{path}: the audio track's header is damaged ({type(exc).__name__}: "
                                    f"{exc}); expected a valid stream") from None
        chunks: list[np.ndarray] = []
        try:
            for frame in container.decode(stream):
                for out in resampler.resample(frame):
                    chunks.append(out.to_ndarray())
            for out in resampler.resample(None):
                chunks.append(out.to_ndarray())
        except Exception as exc:
            if not chunks:
                raise AudioLoadingError(
                    f"{path}: the audio track could not be decoded ({exc}); expected a valid stream"
                ) from None
            log.warning("%s: decoding stopped early (%s); using the %d chunks read", path, exc,
                        len(chunks))
    if not chunks:
        return np.zeros((0, channels), np.float32), sr, channels
    if len({c.shape[0] for c in chunks}) != 1:
        raise AudioLoadingError(f"{path}: the channel count changes inside the audio track; expected one layout")
    data = np.concatenate(chunks, axis=1).T  # (n, ch)
    return np.ascontiguousarray(data, dtype=np.float32), sr, data.shape[1]


def load_audio(path, *, sample_rate: int | None = None) -> Audio:
    """Load speech from an audio or video file as mono float32.

    Parameters
    ----------
    path : str or Path
        wav, flac, ogg, aiff (soundfile); mp3, m4a, mp4, mkv, mov, mpg, webm, … (PyAV).
    sample_rate : int, optional
        Resample to this rate (Hz) with soxr; by default the file's own rate is kept.

    Returns
    -------
    Audio
        ``samples`` float32 ``(n,)`` (channels averaged), ``sample_rate`` in Hz.

    Raises
    ------
    AudioLoadingError
        Missing, empty, truncated or non-audio file; no audio track; zero samples; NaN/inf samples.
    """
    path = Path(path)
    if sample_rate is not None:
        if isinstance(sample_rate, bool) or int(sample_rate) != sample_rate or sample_rate <= 0:
            raise ParameterError(f"sample_rate must be a positive whole number of Hz; got {sample_rate!r}")
    _check_file(path)
    ext = path.suffix.lower()
    if ext not in PYAV_EXTENSIONS:
        _check_riff_wav(path)
        try:
            data, sr, ch = _read_soundfile(path)
            return _finish(path, data, sr, ch, sample_rate, "soundfile")
        except AudioLoadingError:
            raise
        except Exception as sf_exc:  # soundfile.LibsndfileError, RuntimeError, ...
            sf_msg = str(sf_exc)
        log.debug("%s: soundfile failed (%s); trying PyAV", path, sf_msg)
        try:
            data, sr, ch = _read_pyav(path)
        except AudioLoadingError as exc:
            raise AudioLoadingError(
                f"{path}: not a readable audio file (soundfile: {sf_msg}; PyAV: "
                f"{str(exc).split(': ', 1)[-1]})"
            ) from None
        return _finish(path, data, sr, ch, sample_rate, "PyAV")
    data, sr, ch = _read_pyav(path)
    return _finish(path, data, sr, ch, sample_rate, "PyAV")


def audio_info(path) -> dict:
    """What an audio/video file holds, without decoding it all.

    Returns
    -------
    dict with ``path``, ``decoder`` ("soundfile" or "PyAV"), ``sample_rate``, ``channels``,
    ``duration`` (s), ``format`` / ``codec`` description.
    """
    path = Path(path)
    _check_file(path)
    if path.suffix.lower() not in PYAV_EXTENSIONS:
        _check_riff_wav(path)
        try:
            import soundfile as sf

            info = sf.info(str(path))
            sf_ok = True
        except Exception:
            sf_ok = False
        if sf_ok:
            sr = _check_rate(path, info.samplerate, "sample rate")
            if not 1 <= info.channels <= 256 or info.frames < 0:
                raise AudioLoadingError(f"{path}: {info.channels} channels, {info.frames} frames; damaged header?")
            return {"path": str(path), "decoder": "soundfile", "sample_rate": sr,
                    "channels": int(info.channels), "duration": info.frames / sr,
                    "format": f"{info.format} {info.subtype}"}
    import av

    try:
        container = av.open(str(path))
    except Exception as exc:
        raise AudioLoadingError(f"{path}: not a readable audio or video file ({exc})") from None
    with container:
        if not container.streams.audio:
            raise AudioLoadingError(f"{path}: the file has no audio track; expected a file with sound")
        st = container.streams.audio[0]
        try:
            ctx = st.codec_context
            sr = _check_rate(path, getattr(ctx, "sample_rate", None) or st.rate, "the audio track's sample rate")
            dur = None
            if st.duration is not None and st.time_base is not None:
                dur = float(st.duration * st.time_base)
            elif container.duration is not None:
                dur = container.duration / 1_000_000
            if dur is not None and not (np.isfinite(dur) and dur >= 0):
                dur = None
            return {"path": str(path), "decoder": "PyAV", "sample_rate": sr,
                    "channels": int(getattr(ctx, "channels", 0) or 0), "duration": dur,
                    "format": f"{container.format.name} {getattr(ctx, 'name', '?')}"}
        except AudioLoadingError:
            raise
        except Exception as exc:
            raise AudioLoadingError(f"{path}: the audio track's header is damaged ({type(exc).__name__}: "
                                    f"{exc})") from None


def save_audio(audio: Audio, path, *, subtype: str | None = None) -> None:
    """Write mono audio with soundfile, atomically.

    Parameters
    ----------
    audio : Audio
    path : str or Path
        ``.wav`` (PCM_16 by default), ``.flac`` (PCM_16), ``.ogg`` (Vorbis), ``.aiff``.
    subtype : str, optional
        A soundfile subtype such as ``"PCM_24"`` or ``"FLOAT"``.
    """
    import soundfile as sf

    if not isinstance(audio, Audio):
        raise ParameterError(f"save_audio needs an Audio; got {type(audio).__name__}")
    path = Path(path)
    ext = path.suffix.lower()
    if subtype is None:
        if ext not in _SAVE_SUBTYPE:
            raise ParameterError(
                f"{path}: cannot write audio with extension {ext!r}; expected one of "
                f"{', '.join(sorted(_SAVE_SUBTYPE))}"
            )
        subtype = _SAVE_SUBTYPE[ext]
    x = np.asarray(audio.samples, dtype=np.float32)
    if subtype.startswith("PCM") or subtype == "VORBIS":
        x = np.clip(x, -1.0, 1.0)
    fmt = {".wav": "WAV", ".flac": "FLAC", ".ogg": "OGG", ".aiff": "AIFF", ".aif": "AIFF"}.get(ext)
    with atomic_path(path) as tmp:
        sf.write(str(tmp), x, audio.sample_rate, subtype=subtype, format=fmt)


__all__ = ["load_audio", "save_audio", "audio_info", "resample", "PYAV_EXTENSIONS"]
