"""Audio read block by block, so that hours of speech never sit in memory at once.

The seeds are silent on long inputs.  :func:`load_audio` decodes a whole file (3 h of 44.1 kHz
stereo is ~3.8 GB as float64 before the downmix); ``headmotion synth`` on long recordings instead
reads the file here in blocks and feeds a causal model's stream, whose output equals its offline
output (the streaming contract of :mod:`headmotion.systems.base`), so memory stays bounded and
time linear in the length.

Each block is downmixed to mono by averaging the channels (as :func:`load_audio` does) and
resampled on the stream to the requested rate with one ``soxr.ResampleStream`` (HQ, the quality
:func:`headmotion.io.audio.resample` uses; the streamed and one-shot resamplers share the filter
and differ only by rounding, ~1e-6 of full scale).

Libraries: soundfile's ``blocks`` for what libsndfile reads (wav, flac, ogg, …), PyAV's packet
decoder for everything else (mp3, m4a, a video's audio track), python-soxr for the resampling.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from ..errors import AudioLoadingError

#: Seconds of audio per block (about 3 MB of float32 at 16 kHz).
BLOCK_SECONDS = 30.0


def audio_duration(path) -> float:
    """The file's duration in seconds from its header (no decoding); ``nan`` when unknown."""
    p = Path(path)
    try:
        import soundfile as sf

        info = sf.info(str(p))
        if info.samplerate > 0 and info.frames > 0:
            return float(info.frames) / float(info.samplerate)
    except Exception:  # not a libsndfile format: ask the container
        pass
    try:
        import av

        with av.open(str(p)) as c:
            if c.duration is not None:
                return float(c.duration) / 1e6
    except Exception:
        pass
    return float("nan")


def _mono(block: np.ndarray) -> np.ndarray:
    b = np.asarray(block, dtype=np.float32)
    if b.ndim == 2:
        b = b.mean(axis=1, dtype=np.float64).astype(np.float32) if b.shape[1] > 1 else b[:, 0]
    return b


def _soundfile_blocks(p: Path, n: int):
    import soundfile as sf

    info = sf.info(str(p))
    return info.samplerate, (_mono(b) for b in sf.blocks(str(p), blocksize=n, dtype="float32", always_2d=True))


def _pyav_blocks(p: Path):
    import av

    container = av.open(str(p))
    streams = container.streams.audio
    if not streams:
        container.close()
        raise AudioLoadingError(f"{p}: the file has no audio track")
    stream = streams[0]
    rate = int(stream.rate or stream.codec_context.sample_rate)

    def gen():
        try:
            for frame in container.decode(stream):
                a = frame.to_ndarray()
                if a.ndim == 1:
                    a = a[None, :]
                if frame.format.is_planar:
                    x = a.T  # (samples, channels)
                else:
                    x = a.reshape(-1, len(frame.layout.channels))
                if np.issubdtype(x.dtype, np.integer):
                    x = x.astype(np.float32) / float(np.iinfo(x.dtype).max + 1)
                yield _mono(x)
        finally:
            container.close()

    return rate, gen()


def iter_audio_blocks(path, *, sample_rate: int, block_seconds: float = BLOCK_SECONDS) -> Iterator[np.ndarray]:
    """Mono float32 blocks of ``path`` at ``sample_rate`` (the last block flushes the resampler).

    Raises :class:`~headmotion.errors.AudioLoadingError` naming the file when it cannot be read or
    holds non-finite samples."""
    p = Path(path)
    if not p.is_file():
        raise AudioLoadingError(f"{p}: file not found; expected an audio or video file")
    try:
        import soundfile as sf

        n = max(1, min(1 << 15, int(round(block_seconds * sf.info(str(p)).samplerate))))
        rate, blocks = _soundfile_blocks(p, n)
    except Exception:
        try:
            rate, blocks = _pyav_blocks(p)
        except AudioLoadingError:
            raise
        except Exception as exc:
            raise AudioLoadingError(f"{p}: cannot decode the audio ({type(exc).__name__}: {exc})") from None
    rs = None
    if rate != int(sample_rate):
        import soxr

        rs = soxr.ResampleStream(rate, int(sample_rate), 1, dtype="float32", quality="HQ")
    want = max(1, int(round(block_seconds * rate)))
    pending: list[np.ndarray] = []
    have = 0
    offset = 0

    def out(x: np.ndarray, last: bool) -> np.ndarray:
        if not np.all(np.isfinite(x)):
            raise AudioLoadingError(f"{p}: non-finite samples (NaN or inf) near {offset / rate:.1f} s")
        return x if rs is None else np.asarray(rs.resample_chunk(x, last=last), dtype=np.float32)

    try:
        for b in blocks:
            pending.append(b)
            have += len(b)
            if have >= want:
                x = np.concatenate(pending)
                pending, have = [], 0
                yield out(x, False)
                offset += len(x)
    except AudioLoadingError:
        raise
    except Exception as exc:
        raise AudioLoadingError(f"{p}: the audio is damaged near {offset / rate:.1f} s "
                                f"({type(exc).__name__}: {exc})") from None
    tail = np.concatenate(pending) if pending else np.zeros(0, np.float32)
    last = out(tail, True)
    if len(last):
        yield last


__all__ = ["iter_audio_blocks", "audio_duration", "BLOCK_SECONDS"]
