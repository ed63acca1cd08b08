"""``headmotion corpus check`` and ``headmotion corpus import`` (docs/design.md "Corpus on disk")."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from ..errors import ParameterError
from .app import console, corpus_app, err_console, progress_bar

AUDIO_EXT = {".wav", ".flac", ".ogg", ".mp3", ".mp4", ".mkv", ".mpg", ".m4a"}


@corpus_app.command("check")
def check(corpus_dir: Path = typer.Argument(..., help="corpus directory (with corpus.csv)")):
    """Load every file of a corpus and print speakers, tasks, minutes, frame rates and problems."""
    from ..corpus import Corpus, check_corpus

    corpus = Corpus.load(corpus_dir)
    with progress_bar("checking", total=len(corpus)) as update:
        rows, problems = [], []
        for i in range(len(corpus)):
            r, p = check_corpus(corpus.subset([i]))
            rows += r
            problems += p
            update(i + 1)
    from rich.table import Table

    table = Table(title=f"{corpus_dir}: {len(rows)} recordings")
    for col in ("recording", "speaker", "task", "minutes", "fps", "speaking", "trimmed"):
        table.add_column(col, justify="left" if col in ("recording", "speaker", "task") else "right")
    for r in rows:
        table.add_row(r["recording"], r["speaker"], r["task"], _fmt(r["minutes"], ".2f"), _fmt(r["fps"], "g"),
                      _fmt(None if r["speaking"] is None else 100 * r["speaking"], ".0f", "%"),
                      _fmt(r["trimmed_s"], ".3f", " s") if r["trimmed_s"] else "-")
    console.print(table)
    ok = [r for r in rows if r["ok"]]
    speakers = sorted({r["speaker"] for r in ok})
    tasks = sorted({r["task"] for r in ok})
    console.print(f"speakers: {len(speakers)} ({', '.join(speakers)}); tasks: {', '.join(tasks)}; "
                  f"minutes: {sum(r['minutes'] for r in ok):.2f}; frame rates: "
                  f"{', '.join(f'{f:g}' for f in sorted({r['fps'] for r in ok}))}")
    trimmed = [r for r in ok if r["trimmed_s"]]
    if trimmed:
        console.print(f"{len(trimmed)} recording(s) trimmed to the shorter of speech and motion (at most 1 s and "
                      f"2 %; longest cut {max(r['trimmed_s'] for r in trimmed):.3f} s)")
    if problems:
        err_console.print(f"[bold red]{len(problems)} problem(s):[/]")
        for p in problems:
            err_console.print(f"  - {p}", highlight=False)
        raise typer.Exit(1)
    console.print("[green]no problems found[/]")


def _fmt(value, spec: str, unit: str = "") -> str:
    """A table cell: ``-`` for what is not known (never ``nan``)."""
    if value is None or value != value:
        return "-"
    return f"{value:{spec}}{unit}"


def _print_import_summary(summary) -> None:
    for item, check in summary.trimmed:
        console.print(f"  {item.recording}: speech {check.audio_s:.3f} s, motion {check.motion_s:.3f} s → "
                      f"{check.longer} trimmed by {check.trimmed_s:.3f} s", highlight=False)
    for _item, reason in summary.refused:
        err_console.print(f"  refused {reason}", highlight=False)
    for p in summary.problems:
        err_console.print(f"  {p}", highlight=False)
    splits = {}
    for item, _ in summary.accepted:
        splits[item.split or "none"] = splits.get(item.split or "none", 0) + 1
    console.print(f"{summary.manifest}: imported {len(summary.accepted)} recording(s), {summary.minutes:.1f} min "
                  f"({len(summary.trimmed)} trimmed, {len(summary.refused)} refused); split: "
                  + ", ".join(f"{k} {v}" for k, v in sorted(splits.items())))


@corpus_app.command("import-dataset")
def import_dataset_cmd(
    layout: str = typer.Argument(..., help="dataset layout: beat2 or amass"),
    root: Path = typer.Argument(..., help="the dataset's folder, as released"),
    output: Path = typer.Option(..., "-o", "--output", help="corpus directory to create or extend"),
    audio: Optional[Path] = typer.Option(None, "--audio", help="amass: folder with each take's speech (same stem)"),
    speaker: Optional[str] = typer.Option(None, "--speaker", help="amass: one speaker for every take "
                                          "(default: each take's parent folder)"),
    split_file: Optional[Path] = typer.Option(None, "--split-file", help="amass: a split file with columns id,type"),
    additional: bool = typer.Option(False, "--additional", help="beat2: import the 'additional' takes as training data"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="files checked at once"),
    strict: bool = typer.Option(False, "--strict", help="write nothing when any recording is refused"),
):
    """Import a public dataset folder in its own layout (BEAT2, AMASS-style SMPL-X) as a corpus.

    Speech and motion that differ by at most 1 s and 2 % are trimmed to the shorter track (as the
    datasets' own loaders do), and reported; beyond that a recording is refused, naming both
    lengths.  The dataset's split is kept in the manifest (evaluate --protocol split uses it)."""
    from ..datasets import import_dataset

    with progress_bar(f"checking {layout} pairs") as update:
        summary = import_dataset(layout, root, output, audio_dir=audio, speaker=speaker, split_file=split_file,
                                 additional=additional, jobs=jobs, strict=strict,
                                 progress=lambda done, total: update(done, total=total))
    _print_import_summary(summary)
    if summary.refused:
        raise typer.Exit(1)


@corpus_app.command("features")
def features_cmd(
    corpus_dir: Path = typer.Argument(..., help="corpus directory (with corpus.csv)"),
    sets: List[str] = typer.Option(["mfcc"], "--set", help="feature set (repeat for several): mfcc, f0e, fbank, ..."),
    fps: float = typer.Option(100.0, "--fps", help="feature frames per second"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="recordings computed at once (processes)"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler address instead of --jobs"),
):
    """Compute a corpus's speech features once, in parallel, into CORPUS/.features (resumable).

    Each recording is one task; finished files are kept when the build is interrupted and skipped
    when it is run again; a recording whose speech file changed is recomputed."""
    from ..corpus import Corpus
    from ..features import FeatureConfig, available
    from ..feature_cache import build_feature_cache

    unknown = [s for s in sets if s not in available()]
    if unknown:
        raise ParameterError(f"unknown feature set(s) {unknown}; available: {', '.join(available())}")
    corpus = Corpus.load(corpus_dir)
    configs = [FeatureConfig(s, fps=fps) for s in sets]
    with progress_bar("features") as update:
        counts = build_feature_cache(corpus, configs, n_jobs=jobs, scheduler=scheduler,
                                     progress=lambda done, total, desc: update(done, total=total, description=desc))
    console.print(f"{corpus_dir}/.features: {counts['computed']} computed, {counts['cached']} already cached "
                  f"({len(corpus)} recordings × {len(configs)} set(s))")


def pair_by_stem(files) -> dict[str, dict[str, Path]]:
    """Audio and motion files paired by file stem (``take1.wav`` + ``take1.bvh``): stem →
    ``{"audio": path, "motion": path}``; ParameterError for a missing file or an unpaired stem."""
    by_stem: dict[str, dict[str, Path]] = {}
    for f in files:
        if not f.exists():
            raise ParameterError(f"{f}: file not found")
        kind = "audio" if f.suffix.lower() in AUDIO_EXT else "motion"
        by_stem.setdefault(f.stem, {})[kind] = f
    unpaired = [s for s, d in by_stem.items() if len(d) != 2]
    if unpaired:
        raise ParameterError(f"these stems lack an audio or a motion file: {unpaired}")
    return by_stem


@corpus_app.command("import")
def import_files(
    files: List[Path] = typer.Argument(..., help="audio and motion files, paired by file stem"),
    output: Path = typer.Option(..., "-o", "--output", help="corpus directory to create or extend"),
    speaker: str = typer.Option(..., "--speaker", help="speaker of these recordings"),
    task: str = typer.Option("speech", "--task", help="task label, e.g. read or free"),
    copy: bool = typer.Option(False, "--copy", help="copy the files into the corpus directory"),
):
    """Make (or extend) a corpus from audio + motion files that share a stem (take1.wav + take1.bvh)."""
    import shutil

    from ..corpus import Corpus, CorpusEntry, MANIFEST
    from ..datasets import check_pair

    by_stem = pair_by_stem(files)
    checks = {stem: check_pair(d["audio"], d["motion"], recording=stem) for stem, d in sorted(by_stem.items())}
    output.mkdir(parents=True, exist_ok=True)
    existing = Corpus.load(output).entries if (output / MANIFEST).exists() else ()
    entries = list(existing)
    for stem, d in sorted(by_stem.items()):
        paths = {}
        for kind, f in d.items():
            if copy:
                dest = output / f.name
                shutil.copy2(f, dest)
                paths[kind] = Path(f.name)
            else:
                paths[kind] = Path(f.resolve())
        entries.append(CorpusEntry(stem, speaker, task, paths["audio"], paths["motion"]))
    corpus = Corpus(root=output, entries=entries)
    corpus.save(output)
    for stem, c in checks.items():
        if c.trimmed_s > 0:
            console.print(f"  {stem}: speech {c.audio_s:.3f} s, motion {c.motion_s:.3f} s → {c.longer} trimmed by "
                          f"{c.trimmed_s:.3f} s", highlight=False)
    console.print(f"{output / MANIFEST}: {len(entries)} recordings ({len(checks)} imported)")
