"""``headmotion evaluate-speech``: does a model follow voices that have no recorded head?

A thin wrapper over :func:`headmotion.evaluation.protocol.speech_only.speech_coupling`: the
projections are fitted on a corpus's recorded heads (once per speech side: Praat's f0e, the
project's own frame-by-frame reading, energy alone), each model synthesises each speech file (and
its degraded copies) with each seed, and the coupling of the motion to its own speech is tested
against the circular-shift null.  Each ``motion-match`` model is put beside its level, the same
library read by Praat (:mod:`headmotion.evaluation.protocol.levels`), fitted here on the corpus
without ``--level-exclude``'s recordings (the shipped models never see ``mead_lrs3``).

    headmotion evaluate-speech ~/.cache/headmotion/corpus/talking_video --speech-set ../shared/data \
        --systems default,stream --seeds 0-3 --degrade all -o runs/speech_only
"""

from __future__ import annotations

import time
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
    speech: Optional[list[Path]] = typer.Argument(None, help="speech files or folders (searched recursively); "
                                                             "no head needed"),
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
    speech_set: Optional[Path] = typer.Option(
        None, "--speech-set", help="the shared data folder (../shared/data): add the documented speech-only set — "
                                   "its speech/ files not in the corpus, the ZEGGS actor's speech, the bundled examples"),
    sides: str = typer.Option("all", "--sides",
                              help="speech sides of the measure, comma-separated: praat (Praat's f0e, the measure "
                                   "as before), own (the frame-by-frame f0e-live reading), energy (no pitch); 'all'"),
    level: bool = typer.Option(True, "--level/--no-level",
                               help="put each motion-match model beside its Praat-read library (prosody=f0e), "
                                    "fitted on the corpus without --level-exclude"),
    level_exclude: str = typer.Option("mead_lrs3", "--level-exclude",
                                      help="comma-separated recording-id prefixes the level's library leaves out "
                                           "(those the shipped models never saw)"),
):
    """Coupling of each model's motion to its own speech, on speech with no recorded head.

    The motion is scored against the clean speech of each file (a degraded copy changes what the
    model hears, not what was said); per seed, the files are pooled (mean excess, Stouffer's p).
    Every speech side gets its own projections; every motion-match model its level and its
    ratio to it (excess / the level's excess, same side and seeds)."""
    from ..corpus import Corpus
    from ..evaluation.measures.speech_sides import SIDE_DESCRIPTIONS, parse_sides
    from ..evaluation.protocol.degraded import DEGRADATIONS
    from ..evaluation.protocol.speech_only import files_table, pooled_table, speech_coupling
    from ..evaluation.protocol.speech_set import describe, speech_set_files
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
    side_list = parse_sides(sides)
    seed_list = parse_seeds(seeds)
    files = speech_files(list(speech or []))
    if speech_set is not None:
        found, missing = speech_set_files(speech_set)
        for line in missing:
            console.print(f"[yellow]speech set:[/] {line}", highlight=False, soft_wrap=True)
        files += found
    if not files:
        raise ParameterError("no speech: name files or folders, or --speech-set")
    corpus = without_prefixes(Corpus.load(corpus_dir), exclude)
    audio = load_speech(files)
    models, levels, notes = with_levels(names, without_prefixes(corpus, level_exclude) if level else None)
    with progress_bar("coupling on speech") as update:
        rows = speech_coupling(corpus, models, audio, seeds=seed_list, degradations=degs, n_shifts=shifts,
                               sides=side_list, levels=levels,
                               progress=lambda d, t, desc: update(d, total=t, description=desc))
    output.mkdir(parents=True, exist_ok=True)
    keys = ("side", "degradation", "system", "seed", "file", "excess", "p", "score", "level", "ratio")
    buf = [",".join(keys)]
    for r in rows:
        buf.append(",".join(_cell(r.get(k, "")) for k in keys))
    atomic_write_text(output / "speech_coupling.csv", "\n".join(buf) + "\n")
    table = pooled_table(rows)
    sides_md = "\n".join(f"* `{s}`: {SIDE_DESCRIPTIONS[s]}" for s in side_list)
    level_md = "\n".join(f"* {n}" for n in notes)
    atomic_write_text(output / "speech_coupling.md",
                      f"# Coupling on speech with no recorded head\n\nProjections: {corpus_dir} "
                      f"({len(corpus)} recordings), fitted per speech side:\n\n{sides_md}\n\n"
                      f"Speech: {len(audio)} files. Shifts: {shifts}.\n\n"
                      + (f"Levels:\n\n{level_md}\n\n" if notes else "")
                      + f"{table}\n## Files\n\n{files_table(rows, describe)}")
    console.print(table, highlight=False, soft_wrap=True)
    for n in notes:
        console.print(f"level: {n}", highlight=False, soft_wrap=True)
    console.print(f"wrote {output / 'speech_coupling.csv'} and {output / 'speech_coupling.md'}")


def _cell(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def load_speech(files: list[Path]) -> dict:
    """name → Audio at 16 kHz (the stem; the path where two files share a stem)."""
    from ..io import load_audio

    audio = {}
    for f in files:
        key = f.stem if f.stem not in audio else str(f)
        audio[key] = load_audio(f, sample_rate=16000)
    return audio


def with_levels(names: list[str], level_corpus) -> tuple[dict, dict, list[str]]:
    """The models named and, with a ``level_corpus``, the Praat-read level of each ``motion-match``
    one fitted on it (:func:`~headmotion.evaluation.protocol.levels.praat_read_level`).

    Returns
    -------
    (models, levels, notes) — name → model (the levels after the models), model → its level's
    name, and one line per model saying what its level is or why it has none
    """
    from ..evaluation.protocol.levels import level_name, praat_read_level
    from ..synthesis import load_model

    models = {n: load_model(n) for n in names}
    if level_corpus is None:
        return models, {}, []
    if not len(level_corpus):
        raise ParameterError("no recordings left for the level's library after --level-exclude")
    levels, notes, twins = {}, [], {}
    for n, m in models.items():
        t0 = time.perf_counter()
        try:
            twin = praat_read_level(m, level_corpus)
        except ParameterError as exc:
            notes.append(f"{n}: no level ({exc})")
            continue
        twins[level_name(n)] = twin
        levels[n] = level_name(n)
        changed = {k: v for k, v in twin.get_params().items() if m.get_params().get(k) != v}
        notes.append(f"{level_name(n)}: {n}'s settings with {changed}, fitted on {len(level_corpus)} recordings "
                     f"in {time.perf_counter() - t0:.0f} s")
    return {**models, **twins}, levels, notes
