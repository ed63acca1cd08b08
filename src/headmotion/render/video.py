"""Preview videos of head motion with the speech muxed in (thesis §4.2.3 stimuli).

:func:`render_video` draws one motion — or several motions of the same speech side by side in a
grid with labels (ground truth vs systems) — with :class:`~headmotion.render.offscreen.HeadRenderer`
at the motion's frame rate and pipes the raw frames into ffmpeg, which encodes H.264 ``yuv420p``
(plays everywhere) and muxes the audio as AAC.  Frame ``i`` is shown from ``i / fps`` seconds and
the audio starts at 0, so picture and sound are in sync by construction; the output is cut to the
motion's duration.

The ffmpeg binary is the one bundled with imageio-ffmpeg (``imageio_ffmpeg.get_ffmpeg_exe()``),
so no system ffmpeg is needed.  PyAV could encode too, but driving the ffmpeg binary through a
pipe keeps encoding in another process (it runs in parallel with rendering).
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from ..errors import HeadMotionError, MissingDependencyError, ParameterError
from ..types import Audio, Motion


def ffmpeg_exe() -> str:
    """Path of imageio-ffmpeg's bundled ffmpeg (or ``$IMAGEIO_FFMPEG_EXE``)."""
    try:
        import imageio_ffmpeg
    except ImportError as exc:  # pragma: no cover - a dependency
        raise MissingDependencyError(f"video output needs imageio-ffmpeg ({exc})") from exc
    return imageio_ffmpeg.get_ffmpeg_exe()


class FFmpegWriter:
    """Pipe raw RGB frames into ffmpeg → H.264 yuv420p MP4 (with optional audio).

    Parameters
    ----------
    path : output file (``.mp4``; ``.mkv``/``.mov`` work too)
    size : (width, height), even
    fps : frames per second
    audio_path : a file ffmpeg can read, or None
    duration : seconds to keep (cuts the audio to the video), or None
    crf, preset : x264 quality and speed
    """

    def __init__(self, path, *, size, fps: float, audio_path=None, duration: float | None = None,
                 crf: int = 20, preset: str = "veryfast"):
        self.path = Path(path)
        w, h = size
        cmd = [ffmpeg_exe(), "-y", "-hide_banner", "-loglevel", "error", "-nostdin",
               "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-framerate", repr(float(fps)),
               "-i", "pipe:0"]
        if audio_path is not None:
            cmd += ["-i", str(audio_path)]
        cmd += ["-map", "0:v:0"]
        if audio_path is not None:
            cmd += ["-map", "1:a:0", "-c:a", "aac", "-b:a", "160k"]
        cmd += ["-c:v", "libx264", "-preset", preset, "-crf", str(int(crf)), "-pix_fmt", "yuv420p",
                "-movflags", "+faststart"]
        if duration is not None:
            cmd += ["-t", f"{float(duration):.6f}"]
        cmd += [str(self.path)]
        self.cmd = cmd
        self._stderr = tempfile.TemporaryFile()
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                     stderr=self._stderr, bufsize=0)
        self.n_frames = 0

    def write(self, frame) -> None:
        """Write one frame: ``(H, W, 3)`` uint8 array or a bytes-like object of that size."""
        try:
            self.proc.stdin.write(frame)
        except (BrokenPipeError, OSError):
            self._fail("ffmpeg stopped accepting frames")
        self.n_frames += 1

    def _fail(self, what: str):
        self.proc.kill()
        self.proc.wait()
        self._stderr.seek(0)
        msg = self._stderr.read().decode(errors="replace").strip()
        raise HeadMotionError(f"{what} while writing {self.path}: {msg or 'no message'}")

    def close(self) -> None:
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        rc = self.proc.wait()
        if rc != 0:
            self._stderr.seek(0)
            msg = self._stderr.read().decode(errors="replace").strip()
            raise HeadMotionError(f"ffmpeg failed ({rc}) writing {self.path}: {msg}")
        self._stderr.close()

    def abort(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self._stderr.close()


def _as_motions(motions) -> list[Motion]:
    if isinstance(motions, Motion):
        return [motions]
    out = list(motions)
    if not out:
        raise ParameterError("render_video needs at least one motion")
    for m in out:
        if not isinstance(m, Motion):
            raise ParameterError(f"expected Motion objects; got {type(m).__name__}")
    return out


def _grid_shape(n: int, grid=None) -> tuple[int, int]:
    if grid is not None:
        rows, cols = (int(v) for v in grid)
        if rows * cols < n:
            raise ParameterError(f"grid {rows}x{cols} has fewer cells than the {n} motions")
        return rows, cols
    if n <= 4:
        return 1, n
    cols = int(np.ceil(np.sqrt(n)))
    return int(np.ceil(n / cols)), cols


def _audio_file(audio, tmpdir: str):
    """A path ffmpeg can read for ``audio`` (Audio object → temporary WAV)."""
    if audio is None:
        return None
    if isinstance(audio, Audio):
        import soundfile as sf

        path = os.path.join(tmpdir, "audio.wav")
        sf.write(path, np.clip(audio.samples, -1, 1), audio.sample_rate, subtype="PCM_16")
        return path
    p = Path(audio)
    if not p.is_file():
        from ..errors import AudioLoadingError

        raise AudioLoadingError(f"audio file not found: {p}")
    return str(p)


def render_video(motions, out, *, audio=None, style: str = "textured", size=(640, 480),
                 labels=None, mask: bool = True, fps: float | None = None, grid=None,
                 crf: int = 20, preset: str = "veryfast", samples: int = 0,
                 translation: bool = True, progress=None) -> dict:
    """Render head motion to an H.264 MP4 with the speech muxed in.

    Parameters
    ----------
    motions : Motion or list of Motion
        One motion, or several (of the same speech) drawn side by side in a grid.
    out : str or Path, the ``.mp4`` to write (atomically: a failure leaves no partial file)
    audio : Audio, path of an audio file, or None
    style : {"textured", "smooth", "silhouette"} (thesis §4.2.3)
    size : (int, int) or "WxH", pixels of one grid cell (even)
    labels : list of str, one per motion (shown on each cell), or None
    mask : bool, black boxes over the eyes and mouth (default True, the thesis's choice)
    fps : frame rate of the video; default the (first) motion's; motions at another rate are
        resampled (Slerp)
    grid : (rows, cols) or None (one row for ≤ 4 motions, else near-square)
    crf, preset : x264 quality (lower = better) and speed
    translation : bool, move the head by ``Motion.translation`` when present (about the clip's
        mean position, so a constant offset from the torso does not lift the head off the neck)
    samples : multisampling for anti-aliasing (0 = off, the default; 4 looks smoother and
        renders about 3× slower on the CPU rasteriser)
    progress : callable ``progress(done, total)`` or None

    Returns
    -------
    dict with ``path``, ``frames``, ``fps``, ``size`` (whole frame), ``seconds`` (wall time) and
    ``render_fps`` (frames per second achieved, rendering + readback + encoding)
    """
    from ..io.atomic import atomic_path
    from .offscreen import HeadRenderer, parse_size

    ms = _as_motions(motions)
    if labels is not None:
        labels = [str(s) for s in labels]
        if len(labels) != len(ms):
            raise ParameterError(f"{len(labels)} labels given for {len(ms)} motions")
    rate = float(fps) if fps is not None else ms[0].fps
    if not np.isfinite(rate) or rate <= 0 or rate > 240:
        raise ParameterError(f"fps must be in (0, 240]; got {rate!r}")
    ms = [m.resample(rate) for m in ms]
    n_frames = max(len(m) for m in ms)
    rows, cols = _grid_shape(len(ms), grid)
    parse_size(size)
    rotvecs = np.zeros((n_frames, len(ms), 3))
    trans = np.zeros((n_frames, len(ms), 3))
    for k, m in enumerate(ms):
        # shorter motions hold their last pose
        idx = np.minimum(np.arange(n_frames), len(m) - 1)
        rotvecs[:, k] = m.rotvec[idx]
        if translation and m.translation is not None:
            trans[:, k] = m.translation[idx] - m.translation.mean(axis=0)
    has_trans = translation and any(m.translation is not None for m in ms)
    duration = n_frames / rate

    with tempfile.TemporaryDirectory(prefix="headmotion-render-") as tmpdir:
        audio_path = _audio_file(audio, tmpdir)
        with HeadRenderer(size=size, style=style, mask=mask, grid=(rows, cols), labels=labels,
                          samples=samples) as renderer:
            with atomic_path(out) as tmp:
                writer = FFmpegWriter(tmp, size=(renderer.width, renderer.height), fps=rate,
                                      audio_path=audio_path, duration=duration, crf=crf, preset=preset)
                t0 = time.perf_counter()
                try:
                    # the pipe write runs in a thread so that rendering frame i+1 overlaps it
                    pending: threading.Thread | None = None
                    bufs = [bytearray(renderer.width * renderer.height * 3) for _ in range(2)]
                    for i in range(n_frames):
                        frame = renderer.render_into(rotvecs[i], trans[i] if has_trans else None)
                        if pending is not None:
                            pending.join()
                        buf = bufs[i % 2]
                        buf[:] = frame
                        pending = threading.Thread(target=writer.write, args=(buf,))
                        pending.start()
                        if progress is not None and (i % 25 == 0 or i == n_frames - 1):
                            progress(i + 1, n_frames)
                    if pending is not None:
                        pending.join()
                    writer.close()
                except BaseException:
                    writer.abort()
                    raise
                elapsed = time.perf_counter() - t0
            width, height = renderer.width, renderer.height
    return {"path": str(out), "frames": n_frames, "fps": rate, "size": (width, height),
            "seconds": elapsed, "render_fps": n_frames / max(elapsed, 1e-9)}


def probe(path) -> dict:
    """Streams of a media file as ffmpeg reports them: ``{"video": str, "audio": str | None,
    "duration": float}`` (used by tests and ``headmotion info``)."""
    r = subprocess.run([ffmpeg_exe(), "-hide_banner", "-i", str(path)], capture_output=True, text=True)
    video = audio = None
    duration = float("nan")
    for line in r.stderr.splitlines():
        line = line.strip()
        if "Stream #" in line and "Video:" in line and video is None:
            video = line.split("Video:", 1)[1].strip()
        elif "Stream #" in line and "Audio:" in line and audio is None:
            audio = line.split("Audio:", 1)[1].strip()
        elif line.startswith("Duration:"):
            t = line.split(",")[0].split("Duration:")[1].strip()
            try:
                h, m, s = t.split(":")
                duration = int(h) * 3600 + int(m) * 60 + float(s)
            except ValueError:
                pass
    return {"video": video, "audio": audio, "duration": duration}


def read_frames(path) -> np.ndarray:
    """Decode a video to ``(T, H, W, 3)`` uint8 (for tests and checks)."""
    import imageio_ffmpeg

    gen = imageio_ffmpeg.read_frames(str(path), output_params=None)
    meta = next(gen)
    w, h = meta["size"]
    frames = [np.frombuffer(f, np.uint8).reshape(h, w, 3) for f in gen]
    return np.stack(frames) if frames else np.zeros((0, h, w, 3), np.uint8)


def benchmark(*, n_frames: int = 300, size=(640, 480), style: str = "textured", samples: int = 0,
              out=None) -> dict:
    """Frames per second of :func:`render_video` (render + readback + pipe to ffmpeg + x264).

    Also reports CPU milliseconds per frame of this process (OpenGL on llvmpipe, Python) and of
    ffmpeg, which tell what an idle machine would do when the measured one is busy.
    Returns ``{"frames", "size", "wall_fps", "cpu_ms_render", "cpu_ms_ffmpeg", "load"}``."""
    import resource

    fps = 25.0
    t = np.arange(n_frames) / fps
    rv = np.stack([0.2 * np.sin(2 * np.pi * 0.5 * t), 0.3 * np.sin(2 * np.pi * 0.3 * t),
                   0.1 * np.sin(2 * np.pi * 0.7 * t)], 1)
    from .mesh import build_head_mesh

    build_head_mesh(detail=1)  # not part of the per-frame cost
    with tempfile.TemporaryDirectory() as d:
        target = out or os.path.join(d, "bench.mp4")
        s0 = resource.getrusage(resource.RUSAGE_SELF)
        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        info = render_video(Motion(rv, fps), target, size=size, style=style, samples=samples)
        s1 = resource.getrusage(resource.RUSAGE_SELF)
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = lambda a, b: (b.ru_utime + b.ru_stime - a.ru_utime - a.ru_stime) * 1000 / n_frames  # noqa: E731
    return {"frames": n_frames, "size": info["size"], "wall_fps": info["render_fps"],
            "cpu_ms_render": cpu(s0, s1), "cpu_ms_ffmpeg": cpu(c0, c1), "load": os.getloadavg()[0]}


__all__ = ["render_video", "FFmpegWriter", "ffmpeg_exe", "probe", "read_frames", "benchmark"]
