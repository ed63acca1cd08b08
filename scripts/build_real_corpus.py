#!/usr/bin/env python
"""Rebuild headmotion's real corpus from ../shared/data/talking_video/.

    python scripts/build_real_corpus.py [OUT_DIR] [--data DIR] [--fps 25] [--lowpass 8] [--no-plots]

OUT_DIR defaults to ~/.cache/headmotion/corpus/talking_video.  Face landmarks of each video are
cached in OUT_DIR/.cache (keyed by file path, size and mtime), so a re-run only redoes the cheap
pose/quality steps; delete that folder to start from scratch.  Writes OUT_DIR/corpus.csv, one
16 kHz .wav and one .npz motion file per recording, OUT_DIR/quality.csv, OUT_DIR/summary.json and
(unless --no-plots) a pose plot per recording in OUT_DIR/plots/.

Speakers are named from the folder and file names: andrew, feifeili, reagan, kristinoem
(styletalk), french (dfrf), each HDTF clip of sadtalker and each mimictalk clip its own person,
each PC-AVS clip its own id except 741400104 / 741400163 (probably the same speaker, README),
each GRID sentence its own speaker (the 11 clips are 11 speakers), MEAD by actor id (M003 has two
clips), LRS3 by YouTube id, and each video_retalking clip its own speaker.  Recording ids are
``<folder>_<file stem>`` (plus ``_partN`` where a video was split at a cut or a long gap); each
recording's ``source`` is its folder (``evaluate --protocol sources`` holds them out in turn).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "talking_video"
DEFAULT_OUT = Path.home() / ".cache" / "headmotion" / "corpus" / "talking_video"
VIDEO_EXT = {".mp4", ".mpg", ".mov", ".avi", ".mkv", ".webm"}


def speaker_for(folder: str, stem: str) -> str:
    """Speaker name from a talking_video folder and file stem (see the module docstring)."""
    s = stem
    if folder == "dfrf":
        return s.lower()
    if folder == "styletalk":
        return re.split(r"_clip", s)[0].lower()
    if folder == "sadtalker":
        m = re.match(r"RD_(Radio\d+)_\d+$", s) or re.match(r"(?:WDA|WRA)_([A-Za-z]+?)\d*_\d+$", s)
        return (m.group(1) if m else s).lower()  # RD_Radio2 and RD_Radio34 are different shows
    if folder == "mimictalk":
        return s.split("_")[0].lower()
    if folder == "pc_avs":
        num = s.split("_")[-1]
        if num in ("741400104", "741400163"):
            return "pcavs_7414"
        return f"pcavs_{num}"
    if folder == "grid":
        return f"grid_{s.split('_')[-1]}"
    if folder == "mead_lrs3":
        if s.startswith("MEAD_"):
            return f"mead_{s.split('_')[1].lower()}"
        if s.startswith("LRS3_"):
            return f"lrs3_{s.split('_')[1].lower()}"
    if folder == "video_retalking":
        return f"retalking_{s}"
    return re.sub(r"[^a-z0-9]+", "_", f"{folder}_{s}".lower()).strip("_")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", nargs="?", type=Path, default=DEFAULT_OUT, help=f"corpus directory (default {DEFAULT_OUT})")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="talking_video folder")
    ap.add_argument("--fps", type=float, default=25.0, help="output motion frame rate (0 = each video's own; default 25)")
    ap.add_argument("--lowpass", type=float, default=8.0, help="pose low-pass cutoff in Hz (0 = off; default 8)")
    ap.add_argument("--no-plots", action="store_true", help="skip the pose plot PNGs")
    args = ap.parse_args(argv)

    from rich.console import Console

    from headmotion.cli.app import progress_bar
    from headmotion.errors import HeadMotionError
    from headmotion.video.build import VideoJob, build_corpus, read_quality_csv, safe_id
    from headmotion.video.quality import format_quality_table

    console = Console(width=200)
    if not args.data.is_dir():
        console.print(f"[red]error:[/] talking_video folder not found: {args.data}")
        return 2
    videos = sorted(p for p in args.data.rglob("*") if p.suffix.lower() in VIDEO_EXT)
    jobs = [VideoJob(video=v, speaker=speaker_for(v.parent.name, v.stem),
                     rec_id=safe_id(f"{v.parent.name}_{v.stem}")) for v in videos]
    console.print(f"{len(jobs)} videos from {args.data} → {args.out}")
    out = args.out.expanduser()
    t0 = time.time()
    state = {"i": 0}

    import contextlib

    @contextlib.contextmanager
    def factory(job):
        state["i"] += 1
        if not sys.stderr.isatty():
            console.print(f"[{state['i']}/{len(jobs)}] {job.video.parent.name}/{job.video.name} ({job.speaker})")
        with progress_bar(f"[{state['i']}/{len(jobs)}] {job.video.parent.name}/{job.video.name}") as update:
            yield lambda done, total: update(done, total=total)

    def on_error(job, exc: HeadMotionError):
        console.print(f"[red]skipped[/] {job.video}: {exc}")

    rows, failures = build_corpus(
        jobs, out, fps=args.fps or None, lowpass=args.lowpass or None, cache_dir=out / ".cache",
        progress_factory=factory, on_error=on_error, plot_dir=None if args.no_plots else out / "plots")
    # keep the manifest to exactly the videos of this run (drop recordings of removed videos)
    from headmotion.corpus import Corpus

    ids = {r["recording"] for r in rows}
    corpus = Corpus.load(out)
    # each recording's source is its video's folder (a dataset's own release): evaluate --protocol sources
    folders = sorted({j.video.parent.name for j in jobs}, key=len, reverse=True)
    source = {e.recording: next((f for f in folders if e.recording.startswith(f + "_")), None) for e in corpus.entries}
    Corpus(root=out, entries=[dataclasses.replace(e, source=source[e.recording]) for e in corpus.entries
                              if e.recording in ids]).save(out)
    quality = [r for r in read_quality_csv(out / "quality.csv") if r["recording"] in ids]
    from headmotion.video.build import write_quality_csv

    spk = {r["recording"]: r.get("speaker", "") for r in rows}
    for r in quality:
        r["speaker"] = spk.get(r["recording"], "")
    write_quality_csv(quality, out / "quality.csv")
    console.print(format_quality_table(rows))
    speakers = sorted({j.speaker for j in jobs if any(r["source"] == j.video.name and r.get("speaker") == j.speaker for r in rows)})
    minutes = sum(float(r["seconds"]) for r in rows) / 60.0
    summary = {"recordings": len(rows), "speakers": speakers, "n_speakers": len(speakers),
               "minutes": round(minutes, 3), "fps": args.fps or "native", "lowpass_hz": args.lowpass,
               "failed": [{"video": str(j.video), "error": m} for j, m in failures],
               "per_speaker_minutes": {s: round(sum(float(r["seconds"]) for r in rows if r.get("speaker") == s) / 60, 3)
                                       for s in speakers},
               "build_seconds": round(time.time() - t0, 1)}
    from headmotion.io.atomic import atomic_write_text

    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2))
    console.print(f"{len(rows)} recordings, {len(speakers)} speakers, {minutes:.2f} min; "
                  f"{len(failures)} video(s) failed; {time.time() - t0:.0f} s → {out}")
    return 0 if rows else 1


if __name__ == "__main__":
    sys.exit(main())
