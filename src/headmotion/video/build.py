"""Build a headmotion corpus from talking-face videos (docs/spec.md §8; thesis §3.4 for the data
preparation it mirrors: rigid head rotation relative to a rest pose, audio aligned to the motion,
short dropouts filled, 16 kHz audio).

Pipeline per video: decode frames with timestamps (:mod:`.decode`) → FaceMesh landmarks
(:mod:`.landmarks`) → shot cuts (:func:`.quality.detect_cuts`) → per shot, a rigid reference shape
and the rotation of every frame (:mod:`.pose`) → confidence, missing frames, short gaps
interpolated, long gaps and cuts split the video into parts → resampled onto a uniform time grid
by timestamps (variable / non-integer frame rates) → zero-phase low-pass → optional resampling to
``fps`` → one :class:`~headmotion.corpus.Recording` per part, with the audio cut to the same
time span.

The expensive half (decoding + landmarks + audio) is a :class:`VideoAnalysis`, which can be cached
as an ``.npz`` keyed by the file's path, size and modification time (:func:`analyse_cached`), so
re-running a build only redoes the cheap pose and quality steps.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..errors import FormatError, HeadMotionError, ParameterError
from ..types import Audio, Motion
from . import quality as q
from .decode import (CORPUS_SAMPLE_RATE, find_sidecar_audio, iter_frames, load_external_audio, probe,
                     read_audio_track)
from .landmarks import LandmarkTrack, track_landmarks
from .pose import RIGID_LANDMARKS, estimate_pose

#: Bumped whenever the cached analysis would change (landmarks, audio decoding).
ANALYSIS_VERSION = 1
DEFAULT_MAX_SIDE = 640
TASK = "video"

Progress = Callable[[int, int], None]


@dataclass(frozen=True, eq=False)
class VideoAnalysis:
    """Decoded landmarks and audio of one video (the part worth caching).

    Attributes
    ----------
    source : str, the video path
    landmarks : LandmarkTrack
    fps : float, nominal frame rate (container's average; refined from timestamps)
    audio : Audio or None, 16 kHz mono, sample 0 at the first video frame
    audio_source : str, where the audio came from ("track", a .wav path, or "")
    image_diff : np.ndarray [shape=(T,)] or None, mean absolute change of a 32 × 32 grey
        thumbnail into each frame (0 for the first), for the picture-change cut test; None in
        analyses cached before it existed (those still load; the test is then skipped)
    """

    source: str
    landmarks: LandmarkTrack
    fps: float
    audio: Audio | None
    audio_source: str = ""
    image_diff: np.ndarray | None = None

    def save(self, path) -> None:
        from ..io.atomic import atomic_path

        arrays = {f"lm_{k}": v for k, v in self.landmarks.to_arrays().items()}
        meta = {"source": self.source, "fps": self.fps, "audio_source": self.audio_source,
                "version": ANALYSIS_VERSION}
        if self.audio is not None:
            arrays["audio"] = self.audio.samples
            meta["sample_rate"] = self.audio.sample_rate
        if self.image_diff is not None:
            arrays["image_diff"] = np.asarray(self.image_diff, np.float32)
        arrays["meta"] = np.array(json.dumps(meta))
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, **arrays)

    @classmethod
    def load(cls, path) -> "VideoAnalysis":
        with np.load(path, allow_pickle=False) as d:
            meta = json.loads(str(d["meta"]))
            if meta.get("version") != ANALYSIS_VERSION:
                raise FormatError(f"cached analysis version {meta.get('version')} != {ANALYSIS_VERSION}", path=path)
            lm = LandmarkTrack.from_arrays({k[3:]: d[k] for k in d.files if k.startswith("lm_")})
            audio = Audio(d["audio"], meta["sample_rate"]) if "audio" in d.files else None
            diff = np.asarray(d["image_diff"], float) if "image_diff" in d.files else None
        if diff is not None and len(diff) != len(lm):
            diff = None
        return cls(meta["source"], lm, float(meta["fps"]), audio, meta.get("audio_source", ""), diff)


def _resolve_audio(video: Path, audio: str | Path | None, has_track: bool) -> tuple[str, Path | None]:
    """Which audio to use: an explicit file, the container's track, or the same-named .wav."""
    if audio is not None:
        a = Path(audio)
        if not a.exists():
            raise FormatError("audio file not found", path=a)
        return "file", a
    if has_track:
        return "track", None
    side = find_sidecar_audio(video)
    if side is not None:
        return "file", side
    raise FormatError(
        "has no audio track and there is no same-named .wav beside it; give the speech with --audio",
        path=video)


def analyse_video(path, *, audio=None, max_side: int | None = DEFAULT_MAX_SIDE,
                  transform: Callable[[np.ndarray], np.ndarray] | None = None,
                  max_frames: int | None = None, progress: Progress | None = None) -> VideoAnalysis:
    """Decode a video, track face landmarks in every frame and load its speech.

    Parameters
    ----------
    path : str or Path, the video
    audio : str or Path, optional
        Speech file to use instead of the video's audio track (needed when the video has none
        and no same-named .wav lies beside it).
    max_side : int or None, frames are scaled to this longer side before FaceMesh (speed only)
    transform : callable, optional, applied to every RGB frame (tests: flips, rotations)
    max_frames : int, optional, stop after this many frames (tests)
    progress : callable(done, total), optional

    Raises
    ------
    FormatError
        Missing / corrupt / audio-less (without .wav) video, or a video without frames.
    """
    path = Path(path)
    info = probe(path)
    kind, audio_path = _resolve_audio(path, audio, info.has_audio)
    total = info.estimated_frames
    if max_frames is not None:
        total = min(total, max_frames) if total else max_frames
    frames = iter_frames(path, max_side=max_side, transform=transform)
    if max_frames is not None:
        import itertools

        frames = itertools.islice(frames, max_frames)
    diffs: list[float] = []

    def watched(it):  # the picture change between frames, for cut detection
        prev = None
        for t, rgb in it:
            th = q.thumbnail(rgb)
            diffs.append(0.0 if prev is None else float(np.abs(th - prev).mean()))
            prev = th
            yield t, rgb

    lm = track_landmarks(watched(frames), width=info.width, height=info.height,
                         progress=None if progress is None else (lambda n: progress(n, max(total, n))))
    if len(lm) == 0:
        raise FormatError("contains no decodable video frames", path=path)
    # the container's average rate (a variable-rate clip such as 30 fps with dropped frames keeps
    # its true average, e.g. 22.13 fps); frames are placed on that grid by their timestamps
    fps = info.fps
    if not fps > 0:
        span = float(lm.times[-1] - lm.times[0])
        fps = (len(lm) - 1) / span if len(lm) > 1 and span > 0 else 25.0
    t0 = float(lm.times[0])
    if kind == "track":
        snd = read_audio_track(path, start_time=t0, sample_rate=CORPUS_SAMPLE_RATE)
        src = "track"
        if snd is None:
            raise FormatError("its audio track holds no decodable audio; give the speech with --audio", path=path)
    else:
        snd = load_external_audio(audio_path, sample_rate=CORPUS_SAMPLE_RATE)
        src = str(audio_path)
    if max_frames is not None and snd is not None:
        snd = snd.slice_seconds(0, (lm.times[-1] - t0) + 1.0 / fps)
    return VideoAnalysis(str(path), lm, float(fps), snd, src, np.asarray(diffs, float))


def cache_key(path, audio=None, max_side=DEFAULT_MAX_SIDE) -> str:
    """A key that changes when the video (or its audio) file or the analysis settings change."""
    p = Path(path).resolve()
    if not p.is_file():
        raise FormatError("video file not found", path=path)
    st = p.stat()
    parts = [str(p), str(st.st_size), str(st.st_mtime_ns), str(max_side), str(ANALYSIS_VERSION)]
    side = Path(audio) if audio is not None else find_sidecar_audio(p)
    if side is not None and Path(side).exists():
        s2 = Path(side).stat()
        parts += [str(Path(side).resolve()), str(s2.st_size), str(s2.st_mtime_ns)]
    return hashlib.sha1("|".join(parts).encode()).hexdigest()[:16]


def analyse_cached(path, cache_dir, *, audio=None, max_side=DEFAULT_MAX_SIDE,
                   progress: Progress | None = None) -> tuple[VideoAnalysis, bool]:
    """:func:`analyse_video` with an on-disk cache; returns ``(analysis, was_cached)``."""
    if cache_dir is None:
        return analyse_video(path, audio=audio, max_side=max_side, progress=progress), False
    cache_dir = Path(cache_dir)
    f = cache_dir / f"{safe_id(Path(path).stem)}-{cache_key(path, audio, max_side)}.npz"
    if f.exists():
        try:
            return VideoAnalysis.load(f), True
        except (HeadMotionError, OSError, ValueError, KeyError):
            pass  # damaged or old cache: recompute
    a = analyse_video(path, audio=audio, max_side=max_side, progress=progress)
    cache_dir.mkdir(parents=True, exist_ok=True)
    a.save(f)
    return a, False


@dataclass
class VideoPart:
    """One recording made from (part of) a video."""

    id: str
    start: int
    stop: int
    motion: Motion
    audio: Audio
    quality: dict = field(default_factory=dict)


def safe_id(name: str) -> str:
    """A recording id / file stem made of letters, digits, ``-``, ``_`` and ``.``."""
    s = re.sub(r"[^A-Za-z0-9._-]+", "_", str(name)).strip("._")
    return s or "video"


def _uniform(times: np.ndarray, rv: np.ndarray, fps: float) -> np.ndarray:
    """Resample ``rv (T, 3)`` at irregular ``times`` onto ``times[0] + k / fps``."""
    n = max(1, int(round((times[-1] - times[0]) * fps)) + 1)
    tg = times[0] + np.arange(n) / fps
    if len(times) == 1:
        return np.repeat(rv, n, axis=0)
    return np.stack([np.interp(tg, times, rv[:, k]) for k in range(3)], axis=1)


def parts_from_analysis(analysis: VideoAnalysis, *, rec_id: str, fps: float | None = None,
                        lowpass: float | None = q.DEFAULT_LOWPASS_HZ,
                        max_gap_s: float = q.DEFAULT_MAX_GAP_S, min_part_s: float = q.DEFAULT_MIN_PART_S,
                        min_confidence: float = q.DEFAULT_MIN_CONFIDENCE, method: str = "kabsch"
                        ) -> list[VideoPart]:
    """Head motion (and matching audio) per part of an analysed video.

    Parameters
    ----------
    analysis : VideoAnalysis
    rec_id : str, recording id; parts of a split video get ``_part1``, ``_part2``, ...
    fps : float, optional, output frame rate (default: the video's)
    lowpass : float or None, cutoff in Hz (:data:`~headmotion.video.quality.DEFAULT_LOWPASS_HZ`)
    max_gap_s : float, gaps up to this long are interpolated, longer ones split the video
    min_part_s : float, shorter parts are dropped
    min_confidence : float, frames below it count as missing
    method : {"kabsch", "pnp"}

    Returns
    -------
    list of VideoPart (ascending time)

    Raises
    ------
    FormatError
        No face in any frame, too few frames, or no part long enough.
    """
    lm = analysis.landmarks
    src = analysis.source
    T = len(lm)
    vfps = float(analysis.fps)
    if lowpass is not None and lowpass < 0:
        raise ParameterError(f"low-pass cutoff must be >= 0 Hz (0 = off); got {lowpass}")
    if fps is not None and fps <= 0:
        raise ParameterError(f"fps must be positive; got {fps}")
    if analysis.audio is None:
        raise FormatError("no audio for this video", path=src)
    min_len = max(2, int(np.ceil(min_part_s * vfps)))
    if T < min_len:
        raise FormatError(f"has only {T} frame(s) ({T / vfps:.2f} s); a recording needs at least "
                          f"{min_part_s:g} s of video with a face", path=src)
    detected = lm.detected
    if not detected.any():
        raise FormatError(f"no face found in any of its {T} frames", path=src)
    P = lm.points[:, RIGID_LANDMARKS].astype(float)
    cuts = q.detect_cuts(P, detected, fps=vfps, image_diff=analysis.image_diff)
    bounds = [0] + cuts + [T]
    rotvec, residual = _fit_shots(lm, P, detected, bounds, method)
    conf = q.confidence(P, residual, width=lm.width, height=lm.height, n_faces=lm.n_faces)
    usable = conf >= min_confidence
    rotvec[~usable] = np.nan
    # fill short gaps within each shot (never across a cut)
    filled, gaps_all = _fill_shot_gaps(rotvec, lm.times, bounds, max(0, int(round(max_gap_s * vfps))))
    ok_rows = np.all(np.isfinite(filled), axis=1)
    segs = q.split_segments(ok_rows, cuts, min_len=min_len)
    if not segs:
        raise FormatError(
            f"no stretch of at least {min_part_s:g} s with a usable face (face found in "
            f"{detected.mean():.0%} of {T} frames, usable in {usable.mean():.0%})", path=src)
    two = float(np.mean(lm.n_faces > 1))
    parts: list[VideoPart] = []
    t_first = float(lm.times[0])
    audio = analysis.audio
    for k, (a, b) in enumerate(segs, start=1):
        pid = rec_id if len(segs) == 1 else f"{rec_id}_part{k}"
        times = lm.times[a:b]
        rv = _uniform(times, filled[a:b], vfps)
        rv = q.lowpass(rv, vfps, lowpass)
        start_s = float(times[0] - t_first)
        meta = {"source": Path(src).name, "start_s": round(start_s, 4), "frames": [int(a), int(b)],
                "pose": method, "lowpass_hz": lowpass or 0, "video_fps": vfps,
                "audio": analysis.audio_source}
        motion = Motion(rv, vfps, meta=meta)
        if fps is not None and abs(fps - vfps) > 1e-6:
            motion = motion.resample(fps)
        snd = audio.slice_seconds(start_s, start_s + motion.duration)
        if snd.duration < motion.duration - 1.0 / motion.fps - 0.05:
            # audio ends early (or a short .wav): keep the span both cover
            n = int(np.floor(snd.duration * motion.fps))
            if n < max(2, int(min_part_s * motion.fps)):
                continue
            motion = motion.slice_frames(0, n)
        in_part = [(g0, g1, okg) for g0, g1, okg in gaps_all if a <= g0 and g1 <= b]
        row = _quality_row(pid, src, motion, detected[a:b], conf[a:b], two, in_part, len(cuts))
        parts.append(VideoPart(pid, int(a), int(b), motion, snd, row))
    if not parts:
        raise FormatError("the audio does not cover any part of the video with a face", path=src)
    return parts


def _fit_shots(lm, P: np.ndarray, detected: np.ndarray, bounds: list[int], method: str):
    """Rotation vectors and fit residuals per frame, the pose fitted shot by shot (between cuts);
    NaN in shots with fewer than 3 detected frames."""
    T = len(P)
    rotvec = np.full((T, 3), np.nan)
    residual = np.full(T, np.nan)
    for a, b in zip(bounds[:-1], bounds[1:]):
        if detected[a:b].sum() >= 3:
            fit = estimate_pose(P[a:b], detected[a:b], method=method, width=lm.width, height=lm.height)
            rotvec[a:b] = fit.rotvec
            residual[a:b] = fit.residual
    return rotvec, residual


def _fill_shot_gaps(rotvec: np.ndarray, times: np.ndarray, bounds: list[int], max_gap: int):
    """Gaps of at most ``max_gap`` frames filled within each shot (never across a cut); returns the
    filled track and every gap as ``(first, end, filled)`` in frames of the whole video."""
    filled = rotvec.copy()
    gaps_all: list[tuple[int, int, bool]] = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        seg, gaps = q.fill_gaps(rotvec[a:b], times[a:b], max_gap=max_gap)
        filled[a:b] = seg
        gaps_all += [(a + g0, a + g1, ok) for g0, g1, ok in gaps]
    return filled, gaps_all


def _quality_row(pid: str, src, motion: Motion, detected: np.ndarray, conf: np.ndarray, two: float,
                 gaps: list, n_cuts: int) -> dict:
    """One row of ``quality.csv`` for a part: detection, confidence, gaps, cuts, SD and jitter."""
    sd = np.degrees(motion.rotvec.std(axis=0))
    jit = q.jitter_deg(motion.rotvec)
    notes = []
    if two > 0.05:
        notes.append(f"two faces in {two:.0%} of frames (kept the tracked one)")
    return {"recording": pid, "source": Path(src).name, "seconds": round(motion.duration, 3),
            "fps": round(motion.fps, 3), "detection": round(float(detected.mean()), 4),
            "confidence": round(float(conf.mean()), 4),
            "two_faces": round(two, 4), "gaps": len(gaps),
            "gaps_filled": int(sum(okg for *_, okg in gaps)), "cuts": n_cuts,
            "sd_pitch": round(float(sd[0]), 3), "sd_yaw": round(float(sd[1]), 3),
            "sd_roll": round(float(sd[2]), 3), "jitter_pitch": round(float(jit[0]), 4),
            "jitter_yaw": round(float(jit[1]), 4), "jitter_roll": round(float(jit[2]), 4),
            "note": "; ".join(notes)}


def write_quality_csv(rows: Sequence[dict], path) -> None:
    import csv
    import io as _io

    from ..io.atomic import atomic_write_text

    buf = _io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(q.QUALITY_COLUMNS), lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def read_quality_csv(path) -> list[dict]:
    import csv

    p = Path(path)
    if not p.exists():
        return []
    with open(p, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k, v in list(r.items()):
            if k in ("recording", "source", "note"):
                continue
            try:
                r[k] = float(v) if v not in ("", None) else v
            except ValueError:
                pass
    return rows


@dataclass
class VideoJob:
    """One video to add to a corpus."""

    video: Path
    speaker: str
    rec_id: str
    audio: Path | None = None


def build_corpus(jobs: Sequence[VideoJob], out_dir, *, fps: float | None = None,
                 lowpass: float | None = q.DEFAULT_LOWPASS_HZ, cache_dir=None,
                 max_side: int | None = DEFAULT_MAX_SIDE, method: str = "kabsch",
                 progress_factory: Callable[[VideoJob], object] | None = None,
                 on_error: Callable[[VideoJob, HeadMotionError], None] | None = None,
                 plot_dir=None) -> tuple[list[dict], list[tuple[VideoJob, str]]]:
    """Add videos to the corpus in ``out_dir`` (created; an existing manifest is kept and the
    entries of these videos replaced).

    Writes ``<id>.wav`` (16 kHz) and ``<id>.npz`` per recording, ``corpus.csv`` and
    ``quality.csv``.

    Parameters
    ----------
    jobs : sequence of VideoJob
    out_dir : path
    fps, lowpass, method : see :func:`parts_from_analysis`
    cache_dir : path, optional, where analyses are cached (re-runs skip tracking)
    progress_factory : callable(job) -> context manager yielding ``update(done, total)``, optional
    on_error : callable(job, error), optional; without it the first error is raised
    plot_dir : path, optional, write a pose plot PNG per recording there

    Returns
    -------
    rows : list of dict, quality rows of the recordings written
    failures : list of (job, message)
    """
    from ..corpus import MANIFEST, Corpus, CorpusEntry
    from ..io import save_audio, save_motion

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ids = [j.rec_id for j in jobs]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise ParameterError(f"two videos would get the same recording id: {dup}; rename or build separately")
    entries: list[CorpusEntry] = []
    if (out / MANIFEST).exists():
        try:
            entries = list(Corpus.load(out).entries)
        except HeadMotionError:
            entries = []
    old_quality = {r["recording"]: r for r in read_quality_csv(out / "quality.csv")}
    rows: list[dict] = []
    failures: list[tuple[VideoJob, str]] = []
    for job in jobs:
        pat = re.compile(re.escape(job.rec_id) + r"(_part\d+)?$")
        try:
            if progress_factory is not None:
                with progress_factory(job) as update:
                    analysis, _ = analyse_cached(job.video, cache_dir, audio=job.audio, max_side=max_side,
                                                 progress=update)
            else:
                analysis, _ = analyse_cached(job.video, cache_dir, audio=job.audio, max_side=max_side)
            parts = parts_from_analysis(analysis, rec_id=job.rec_id, fps=fps, lowpass=lowpass, method=method)
        except HeadMotionError as exc:
            if on_error is None:
                raise
            on_error(job, exc)
            failures.append((job, str(exc)))
            continue
        # replace this video's old entries in place (a re-run keeps the manifest order)
        pos = next((i for i, e in enumerate(entries) if pat.match(e.recording)), len(entries))
        entries = [e for e in entries if not pat.match(e.recording)]
        pos = min(pos, len(entries))
        for k in [k for k in old_quality if pat.match(k)]:
            del old_quality[k]
        new_entries = []
        for part in parts:
            save_audio(part.audio, out / f"{part.id}.wav")
            save_motion(part.motion, out / f"{part.id}.npz")
            new_entries.append(CorpusEntry(part.id, job.speaker, TASK, Path(f"{part.id}.wav"), Path(f"{part.id}.npz")))
            row = dict(part.quality, speaker=job.speaker)
            rows.append(row)
            old_quality[part.id] = row
            if plot_dir is not None:
                plot_pose(part.motion, Path(plot_dir) / f"{part.id}.png", title=f"{part.id} ({job.speaker})")
        entries[pos:pos] = new_entries
        # manifest and quality table after every video, so an interrupted build keeps its work
        Corpus(root=out, entries=entries).save(out)
        write_quality_csv(list(old_quality.values()), out / "quality.csv")
    return rows, failures


def plot_pose(motion: Motion, path, *, title: str = "") -> None:
    """Pitch / yaw / roll (degrees) against time, saved as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io.atomic import atomic_path

    deg = np.degrees(motion.rotvec)
    fig, ax = plt.subplots(figsize=(10, 3.2))
    for k, name in enumerate(("pitch", "yaw", "roll")):
        ax.plot(motion.times, deg[:, k], lw=1, label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("degrees")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90)
    plt.close(fig)


__all__ = ["VideoAnalysis", "VideoPart", "VideoJob", "analyse_video", "analyse_cached", "cache_key",
           "parts_from_analysis", "build_corpus", "safe_id", "plot_pose", "write_quality_csv",
           "read_quality_csv", "TASK", "DEFAULT_MAX_SIDE", "ANALYSIS_VERSION"]
