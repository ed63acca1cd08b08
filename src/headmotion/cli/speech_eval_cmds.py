"""``headmotion evaluate-speech``: does a model follow voices that have no recorded head?

A thin wrapper over :func:`headmotion.evaluation.protocol.speech_only.speech_coupling`: the
projections are fitted on a corpus's recorded heads, each model synthesises each speech file (and
its degraded copies) with each seed, and the coupling of the motion to its own speech is tested
against the circular-shift null.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import FormatError, ParameterError
from .app import app, console, progress_bar

#: audio files a folder of speech is searched for
SPEECH_SUFFIXES = (".wav", ".flac", ".mp3", ".ogg", ".m4a")


def parse_seeds(text: str) -> list[int]:
    """``"0-3"`` → [0, 1, 2, 3]; ``"1,4,7"`` → [1, 4, 7] (whole numbers ≥ 0)."""
    seeds: list[int] = []
    try:
        for part in (p.strip() for p in text.split(",") if p.strip()):
            if "-" in part:
                lo, hi = (int(x) for x in part.split("-", 1))
                if hi < lo:
                    raise ValueError
                seeds += range(lo, hi + 1)
            else:
                seeds.append(int(part))
    except ValueError:
        raise ParameterError(f"--seeds takes whole numbers and ranges such as 0-3 or 1,4,7; got {text!r}") from None
    if not seeds or min(seeds) < 0:
        raise ParameterError(f"--seeds takes whole numbers ≥ 0; got {text!r}")
    return list(dict.fromkeys(seeds))


def speech_files(paths: list[Path]) -> list[Path]:
    """The audio files named, and those found (recursively, sorted) in the folders named."""
    out: list[Path] = []
    for p in paths:
        if p.is_dir():
            found = sorted(f for f in p.rglob("*") if f.suffix.lower() in SPEECH_SUFFIXES and f.is_file())
            if not found:
                raise FormatError(f"no audio file ({', '.join(SPEECH_SUFFIXES)}) in the folder", path=p)
            out += found
        elif p.is_file():
            out.append(p)
        else:
            raise FormatError("no such file or folder", path=p)
    return out


@app.command("evaluate-speech")
def evaluate_speech_cmd(
    corpus_dir: Path = typer.Argument(..., help="corpus of recorded heads with their speech (the projections)"),
    speech: list[Path] = typer.Argument(..., help="speech files or folders (searched recursively); no head needed"),
    systems: str = typer.Option("default,stream", "--systems", "-s",
                                help="comma-separated trained models: shipped names (default, stream) or model files"),
    output: Path = typer.Option(..., "-o", "--output", help="report directory (speech_coupling.csv, speech_coupling.md)"),
    seeds: str = typer.Option("0-3", "--seeds", help="synthesis seeds, e.g. 0-3 or 1,2,3"),
    degrade: str = typer.Option("clean", "--degrade",
                                help="comma-separated: clean and degraded copies (noise20, telephone, quiet, mp3-64k); "
                                     "'all' for every one"),
    shifts: int = typer.Option(200, "--shifts", min=10, help="circular shifts of the null"),
    exclude: Optional[str] = typer.Option(None, "--exclude",
                                          help="comma-separated recording-id prefixes of the corpus to leave out"),
):
    """Coupling of each model's motion to its own speech, on speech with no recorded head.

    The motion is scored against the clean speech of each file (a degraded copy changes what the
    model hears, not what was said); per seed, the files are pooled (mean excess, Stouffer's p)."""
    from ..corpus import Corpus
    from ..evaluation.protocol.degraded import DEGRADATIONS
    from ..evaluation.protocol.speech_only import pooled_table, speech_coupling
    from ..io import load_audio
    from ..io.atomic import atomic_write_text
    from ..systems.spec import split_systems
    from .eval_cmds import without_prefixes

    names = split_systems(systems)
    if not names:
        raise ParameterError("--systems needs at least one model")
    degs = ["clean", *DEGRADATIONS] if degrade.strip() == "all" else [d.strip() for d in degrade.split(",") if d.strip()]
    bad = [d for d in degs if d != "clean" and d not in DEGRADATIONS]
    if bad or not degs:
        raise ParameterError(f"--degrade takes clean, all or {', '.join(DEGRADATIONS)}; got {degrade!r}")
    seed_list = parse_seeds(seeds)
    files = speech_files(list(speech))
    corpus = Corpus.load(corpus_dir)
    corpus = without_prefixes(corpus, exclude)
    audio = {}
    for f in files:
        key = f.stem if f.stem not in audio else str(f)
        audio[key] = load_audio(f, sample_rate=16000)
    with progress_bar("coupling on speech") as update:
        rows = speech_coupling(corpus, {n: n for n in names}, audio, seeds=seed_list, degradations=degs,
                               n_shifts=shifts, progress=lambda d, t, desc: update(d, total=t, description=desc))
    output.mkdir(parents=True, exist_ok=True)
    buf = [",".join(("degradation", "system", "seed", "file", "excess", "p", "score"))]
    for r in rows:
        buf.append(",".join(str(r[k]) if not isinstance(r[k], float) else f"{r[k]:.6g}"
                            for k in ("degradation", "system", "seed", "file", "excess", "p", "score")))
    atomic_write_text(output / "speech_coupling.csv", "\n".join(buf) + "\n")
    table = pooled_table(rows)
    atomic_write_text(output / "speech_coupling.md",
                      f"# Coupling on speech with no recorded head\n\nProjections: {corpus_dir} "
                      f"({len(corpus)} recordings). Speech: {len(audio)} files. Shifts: {shifts}.\n\n{table}")
    console.print(table, highlight=False, soft_wrap=True)
    console.print(f"wrote {output / 'speech_coupling.csv'} and {output / 'speech_coupling.md'}")
