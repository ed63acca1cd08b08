"""``headmotion corpus from-video``: a corpus from talking-face videos (docs/spec.md §8).

Thin: parses the options, builds :class:`~headmotion.video.build.VideoJob` s, shows one rich
progress bar per video and prints the quality table; the work is in :mod:`headmotion.video`.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import List, Optional

import typer

from .app import console, corpus_app, err_console, progress_bar


@corpus_app.command("from-video")
def from_video(
    videos: List[Path] = typer.Argument(..., help="Video files (mp4, mpg, mov, ...) of one speaker talking."),
    output: Path = typer.Option(..., "-o", "--output", help="Corpus directory (created; an existing corpus.csv is extended)."),
    speaker: Optional[str] = typer.Option(None, "--speaker", help="Speaker name for all videos (default: each video's file name)."),
    audio: Optional[List[Path]] = typer.Option(None, "--audio", help="Speech file per video, in the same order (default: the video's audio track, else a same-named .wav)."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Resample motion to this frame rate (default: the video's)."),
    lowpass: float = typer.Option(8.0, "--lowpass", help="Low-pass cutoff for the pose in Hz (0 = off). Default 8 Hz: head motion is below it; landmark noise and mouth/blink leakage above."),
    method: str = typer.Option("kabsch", "--method", help="Pose fit: kabsch (3D landmarks, default) or pnp (2D, pinhole camera)."),
    max_side: int = typer.Option(640, "--max-side", help="Scale frames to this longer side before face tracking (speed only)."),
    cache: Optional[Path] = typer.Option(None, "--cache", help="Cache directory for landmarks (default: CORPUS_DIR/.cache); re-runs skip tracking."),
    plots: bool = typer.Option(False, "--plots", help="Also write a pose plot PNG per recording into CORPUS_DIR/plots."),
) -> None:
    """Estimate head rotation from the face in each video and write a corpus (corpus.csv, one
    .wav + .npz per recording, quality.csv)."""
    from ..errors import ParameterError
    from ..video.build import VideoJob, build_corpus, safe_id
    from ..video.quality import format_quality_table

    if audio and len(audio) != len(videos):
        raise ParameterError(f"--audio was given {len(audio)} time(s) for {len(videos)} video(s); give one per video or none")
    jobs = []
    for k, v in enumerate(videos):
        rid = safe_id(v.stem)
        jobs.append(VideoJob(video=v, speaker=speaker or rid, rec_id=rid, audio=audio[k] if audio else None))
    ids = [j.rec_id for j in jobs]
    if len(set(ids)) != len(ids):  # same stem in different folders: prefix the folder
        for j in jobs:
            j.rec_id = safe_id(f"{j.video.parent.name}_{j.video.stem}")

    @contextlib.contextmanager
    def factory(job):
        with progress_bar(f"{job.video.name}", total=None) as update:
            yield lambda done, total: update(done, total=total)

    errors = []

    def on_error(job, exc):
        errors.append(exc)
        if len(videos) > 1:
            err_console.print(f"[bold red]skipped[/] {job.video}: {exc}", highlight=False, soft_wrap=True)

    rows, failures = build_corpus(
        jobs, output, fps=fps, lowpass=lowpass or None, method=method, max_side=max_side,
        cache_dir=cache if cache is not None else Path(output) / ".cache",
        progress_factory=factory, on_error=on_error, plot_dir=Path(output) / "plots" if plots else None)
    if errors and not rows:  # nothing usable: the (first) reason, as one line and an exit code
        raise errors[0]
    console.print(format_quality_table(rows))
    minutes = sum(float(r["seconds"]) for r in rows) / 60.0
    console.print(f"wrote {len(rows)} recording(s), {minutes:.2f} min, to {output}/corpus.csv")
