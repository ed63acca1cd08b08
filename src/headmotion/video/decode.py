"""Decode talking-face video: frames with their timestamps, and the audio track on the same clock.

Implements the decoding step of "a training corpus from ordinary talking video" (docs/spec.md §8,
"train on your own data ... from an ordinary talking video"; the thesis §3.4 requirement that the
audio be aligned to the motion).  Library: PyAV (FFmpeg bindings), chosen over OpenCV's
``VideoCapture`` because it gives exact presentation timestamps (needed for variable and
non-integer frame rates, e.g. a 22.13 fps clip) and decodes the audio stream of the same container,
so speech and frames share one clock.  Frames are scaled by FFmpeg's swscale while converting to
RGB (cheap), so 1920×1080 clips reach the face tracker at a few hundred pixels.

Time origin: frame times are seconds on the container clock; :func:`read_audio_track` returns audio
whose sample 0 is at a given time on that clock (normally the first video frame), padding with
silence or trimming as needed, so an offset between the streams' start times is not lost.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from ..errors import AudioLoadingError, FormatError
from ..io._limits import check_file
from ..types import Audio

#: Sample rate of the audio written into corpora (thesis §3.4: 16 kHz for features).
CORPUS_SAMPLE_RATE = 16000


@dataclass(frozen=True)
class VideoInfo:
    """What a video file holds.

    Attributes
    ----------
    path : Path
    width, height : int, pixels of the coded frames
    fps : float, average frame rate (frames / s) as the container states it (may be non-integer;
        0.0 when the container does not say)
    n_frames : int, frame count stated by the container (0 when unknown; an estimate otherwise)
    duration : float, seconds (estimate)
    has_audio : bool
    codec : str
    """

    path: Path
    width: int
    height: int
    fps: float
    n_frames: int
    duration: float
    has_audio: bool
    codec: str

    @property
    def estimated_frames(self) -> int:
        """``n_frames`` or, when the container does not say, ``round(duration * fps)`` (0 if unknown)."""
        return self.n_frames if self.n_frames > 0 else int(round(self.duration * self.fps))


def _open(path: Path):
    import av

    path = check_file(path, expected="a video file")
    try:
        return av.open(str(path))
    except (av.error.FFmpegError, UnicodeDecodeError, ValueError) as exc:
        raise FormatError(f"cannot open as a video container ({exc})", path=path) from None


def probe(path) -> VideoInfo:
    """Read the stream headers of ``path``.

    Raises
    ------
    FormatError
        The file is missing, empty, corrupt, or has no video stream.
    """
    path = Path(path)
    with _open(path) as c:
        if not c.streams.video:
            raise FormatError("has no video stream (an audio file? give it with --audio instead)", path=path)
        s = c.streams.video[0]
        cc = s.codec_context
        rate = s.average_rate or s.base_rate or s.guessed_rate
        fps = float(rate) if rate else 0.0
        if s.duration is not None and s.time_base is not None:
            duration = float(s.duration * s.time_base)
        elif c.duration is not None:
            duration = c.duration / 1e6
        else:
            duration = 0.0
        if fps <= 0 or not np.isfinite(fps):
            fps = 0.0  # unknown: the caller derives it from the frame timestamps
        return VideoInfo(path=path, width=int(cc.width), height=int(cc.height), fps=fps,
                         n_frames=int(s.frames or 0), duration=duration,
                         has_audio=bool(c.streams.audio), codec=str(cc.name))


def scaled_size(width: int, height: int, max_side: int | None) -> tuple[int, int]:
    """Frame size after scaling so that the longer side is at most ``max_side`` (even numbers)."""
    if not max_side or max(width, height) <= max_side:
        return width, height
    s = max_side / max(width, height)
    return max(2, int(round(width * s / 2)) * 2), max(2, int(round(height * s / 2)) * 2)


def iter_frames(path, *, max_side: int | None = 640,
                transform: Callable[[np.ndarray], np.ndarray] | None = None
                ) -> Iterator[tuple[float, np.ndarray]]:
    """Yield ``(time_s, rgb)`` for every decoded frame of the first video stream.

    Parameters
    ----------
    path : str or Path
    max_side : int or None
        Scale frames (keeping the aspect ratio) so the longer side is at most this many pixels;
        face landmarks are returned in normalised coordinates, so this changes only speed.
    transform : callable, optional
        Applied to each RGB frame (e.g. a horizontal flip or a rotation, used by the tests).

    Yields
    ------
    time_s : float, presentation time on the container clock, seconds
    rgb : np.ndarray [shape=(H, W, 3), dtype=uint8]

    Raises
    ------
    FormatError
        When the file cannot be decoded at all.  A decoding error after some frames ends the
        iteration early (a truncated file keeps the frames before the damage).
    """
    import av

    path = Path(path)
    c = _open(path)
    try:
        if not c.streams.video:
            raise FormatError("has no video stream", path=path)
        s = c.streams.video[0]
        s.thread_type = "AUTO"
        w, h = scaled_size(int(s.codec_context.width), int(s.codec_context.height), max_side)
        tb = float(s.time_base) if s.time_base else None
        rate = s.average_rate or s.base_rate
        step = 1.0 / float(rate) if rate else 0.04
        last_t = None
        n = 0
        try:
            for frame in c.decode(s):
                if frame.pts is not None and tb is not None:
                    t = frame.pts * tb
                elif last_t is not None:
                    t = last_t + step
                else:
                    t = 0.0
                if last_t is not None and t <= last_t:  # duplicate / out-of-order timestamp
                    t = last_t + 1e-6
                last_t = t
                rgb = frame.to_ndarray(format="rgb24", width=w, height=h)
                if transform is not None:
                    rgb = np.ascontiguousarray(transform(rgb))
                n += 1
                yield float(t), rgb
        except av.error.FFmpegError as exc:
            if n == 0:
                raise FormatError(f"cannot decode video frames ({exc})", path=path) from None
            return  # truncated: keep what decoded
    finally:
        c.close()


def read_audio_track(path, *, start_time: float = 0.0, sample_rate: int = CORPUS_SAMPLE_RATE) -> Audio | None:
    """Decode, downmix and resample the first audio stream of a container.

    Parameters
    ----------
    path : str or Path
    start_time : float
        Container time (s) that becomes sample 0 of the result — pass the first video frame's
        time so audio and frames stay in sync even when the streams start at different times.
    sample_rate : int
        Output rate (resampled with soxr, as :func:`headmotion.io.load_audio` does).

    Returns
    -------
    Audio or None when the container has no audio stream.
    """
    import av

    path = Path(path)
    c = _open(path)
    try:
        if not c.streams.audio:
            return None
        s = c.streams.audio[0]
        chunks: list[np.ndarray] = []
        first_t = None
        native_rate = None
        try:
            for frame in c.decode(s):
                x = frame.to_ndarray()
                if x.dtype.kind in "iu":
                    x = x.astype(np.float32) / float(np.iinfo(x.dtype).max)
                x = x.astype(np.float32, copy=False)
                n_ch = len(frame.layout.channels)
                if frame.format.is_planar:
                    x = x.reshape(n_ch, -1).mean(axis=0)
                else:
                    x = x.reshape(-1, n_ch).mean(axis=1)
                if first_t is None:
                    first_t = float(frame.time) if frame.time is not None else 0.0
                    native_rate = int(frame.sample_rate)
                chunks.append(x)
        except av.error.FFmpegError as exc:
            if not chunks:
                raise AudioLoadingError(f"{path}: cannot decode the audio track ({exc})") from None
        if not chunks:
            return None
        samples = np.concatenate(chunks)
        # put sample 0 at start_time
        offset = int(round((first_t - start_time) * native_rate))
        if offset > 0:
            samples = np.concatenate([np.zeros(offset, np.float32), samples])
        elif offset < 0:
            samples = samples[-offset:]
        if native_rate != sample_rate:
            import soxr

            samples = soxr.resample(samples, native_rate, sample_rate, quality="HQ").astype(np.float32)
        return Audio(np.clip(samples, -1.0, 1.0), sample_rate)
    finally:
        c.close()


def load_external_audio(path, *, sample_rate: int = CORPUS_SAMPLE_RATE) -> Audio:
    """Load a separate speech file (e.g. the same-named .wav beside an audio-less video)."""
    from ..io import load_audio

    return load_audio(path, sample_rate=sample_rate)


def find_sidecar_audio(video_path) -> Path | None:
    """The same-named ``.wav`` (or ``.flac``) beside a video, if there is one."""
    video_path = Path(video_path)
    for ext in (".wav", ".WAV", ".flac"):
        p = video_path.with_suffix(ext)
        if p.exists() and p != video_path:
            return p
    return None


__all__ = ["VideoInfo", "probe", "iter_frames", "read_audio_track", "load_external_audio",
           "find_sidecar_audio", "scaled_size", "CORPUS_SAMPLE_RATE"]
