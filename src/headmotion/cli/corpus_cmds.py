"""``headmotion corpus check`` and ``headmotion corpus import`` (docs/design.md "Corpus on disk")."""

from __future__ import annotations

from pathlib import Path
from typing import List

import typer
from rich.table import Table

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
    table = Table(title=f"{corpus_dir}: {len(rows)} recordings")
    for col in ("recording", "speaker", "task", "minutes", "fps", "speaking"):
        table.add_column(col, justify="right" if col in ("minutes", "fps", "speaking") else "left")
    for r in rows:
        table.add_row(r["recording"], r["speaker"], r["task"], f"{r['minutes']:.2f}", f"{r['fps']:g}",
                      f"{100 * r['speaking']:.0f}%" if r["ok"] else "-")
    console.print(table)
    ok = [r for r in rows if r["ok"]]
    speakers = sorted({r["speaker"] for r in ok})
    tasks = sorted({r["task"] for r in ok})
    console.print(f"speakers: {len(speakers)} ({', '.join(speakers)}); tasks: {', '.join(tasks)}; "
                  f"minutes: {sum(r['minutes'] for r in ok):.2f}; frame rates: "
                  f"{', '.join(f'{f:g}' for f in sorted({r['fps'] for r in ok}))}")
    if problems:
        err_console.print(f"[bold red]{len(problems)} problem(s):[/]")
        for p in problems:
            err_console.print(f"  - {p}", highlight=False)
        raise typer.Exit(1)
    console.print("[green]no problems found[/]")


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

    by_stem: dict[str, dict[str, Path]] = {}
    for f in files:
        if not f.exists():
            raise ParameterError(f"{f}: file not found")
        kind = "audio" if f.suffix.lower() in AUDIO_EXT else "motion"
        by_stem.setdefault(f.stem, {})[kind] = f
    unpaired = [s for s, d in by_stem.items() if len(d) != 2]
    if unpaired:
        raise ParameterError(f"these stems lack an audio or a motion file: {unpaired}")
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
    console.print(f"{output / MANIFEST}: {len(entries)} recordings")
