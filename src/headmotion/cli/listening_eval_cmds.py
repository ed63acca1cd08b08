"""``headmotion evaluate-listening``: do a model's listening nods follow the other party's cues?

A thin wrapper over :mod:`headmotion.evaluation.protocol.listening`: conversations built from real
speech (:mod:`headmotion.evaluation.protocol.conversations`), the nods read from the output motion
and the cues from the other's audio by Praat (:mod:`headmotion.evaluation.measures.backchannel`),
beside a head that nods at every cue and one that does not listen.

    headmotion evaluate-listening --corpus ~/.cache/headmotion/corpus/talking_video \
        --shared ../shared/data --set report --models default,stream -o runs/listening
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import FormatError, ParameterError
from .app import app, console, progress_bar
from .speech_eval_cmds import parse_seeds


@app.command("evaluate-listening")
def evaluate_listening_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="report directory (listening.md, listening.csv, a figure)"),
    corpus: Optional[Path] = typer.Option(None, "--corpus", help="talking-video corpus: its voices, and its recorded "
                                                                 "pauses' speeds"),
    shared: Optional[Path] = typer.Option(None, "--shared", help="the shared data folder (../shared/data): its speech/"),
    sets: str = typer.Option("report", "--set", help="conversations: choice, report or all (the listening head's "
                                                      "settings were chosen on choice)"),
    models: str = typer.Option("default,stream", "--models", "-m", help="comma-separated models: shipped names or files"),
    seeds: str = typer.Option("1-3", "--seeds", help="synthesis seeds, e.g. 1-3"),
    degrade: str = typer.Option("clean,noise20,telephone", "--degrade",
                                help="comma-separated conditions of the other party's channel: clean, noise20, "
                                     "telephone, quiet, mp3-64k"),
    listening: float = typer.Option(1.0, "--listening", help="the listening amount (0-3)"),
    shifts: int = typer.Option(1000, "--shifts", min=10, help="circular shifts of the null"),
    levels: bool = typer.Option(True, "--levels/--no-levels", help="also the cue-led and not-listening heads"),
):
    """Nods read from the motion against cues read by Praat, on conversations of real speech."""
    from ..evaluation.protocol.conversations import VOICE_SETS, build_conversations
    from ..evaluation.protocol.listening import group_rows, run_conversation, stream_difference
    from ..evaluation.reporting.listening_report import conversation_figure, listening_table
    from ..io.atomic import atomic_write_text
    from ..listener import check_listening
    from ..synthesis import load_model

    names = [m.strip() for m in models.split(",") if m.strip()]
    if not names:
        raise ParameterError("--models needs at least one model")
    set_names = list(VOICE_SETS) if sets == "all" else [sets]
    conds = tuple(d.strip() for d in degrade.split(",") if d.strip())
    seed_list = parse_seeds(seeds)
    check_listening(listening)
    for p, flag in ((corpus, "--corpus"), (shared, "--shared")):
        if p is not None and not p.is_dir():
            raise FormatError(f"{flag} must be a folder", path=p)
    convs = []
    for s in set_names:
        got, missing = build_conversations(s, corpus=corpus, shared=shared, conditions=conds)
        for line in missing:
            console.print(f"[yellow]{s} set:[/] {line}", highlight=False, soft_wrap=True)
        convs += got
    if not convs:
        raise ParameterError("no conversations: give --corpus and/or --shared with the voices of the set")
    loaded = {n: load_model(n) for n in names}
    rows, runs_by_model = {}, {}
    with progress_bar("listening", total=len(convs) * len(loaded)) as update:
        done = 0
        for n, m in loaded.items():
            runs = []
            for c in convs:
                runs.append(run_conversation(c, m, seeds=seed_list, listening=listening, levels=levels))
                done += 1
                update(done, description=f"{n}: {c.name} ({c.condition})")
            runs_by_model[n], rows[n] = runs, group_rows(runs, shifts=shifts)
    pauses = None
    if corpus is not None:
        from ..corpus import Corpus
        from ..evaluation.measures.waiting import pause_segment_speeds

        recs = [r for r in Corpus.load(corpus) if not r.id.startswith("mead_lrs3") and r.duration >= 4]
        pauses = pause_segment_speeds(recs).percentiles()
    output.mkdir(parents=True, exist_ok=True)
    table = listening_table(rows, pauses=pauses)
    streams = []
    for n, m in loaded.items():
        if getattr(m, "can_stream", True):
            try:
                streams.append(f"* {n}: streamed (20 ms chunks) against offline, largest difference "
                               f"{stream_difference(convs[0], m, seed=seed_list[0], listening=listening):.2g}°")
            except ParameterError as e:
                streams.append(f"* {n}: does not stream ({e})")
    keys = ("model", "voices", "condition", "head", "conversations", "heard_s", "cues", "seed", "nods", "share",
            "shifted", "p", "pooled_p", "speed")
    csv = [",".join(keys)]
    for n, rs in rows.items():
        for r in rs:
            for k, sd in enumerate(seed_list):
                v = (n, r.voices, r.condition, r.head, r.conversations, f"{r.heard_s:.2f}", r.result.n_cues, sd,
                     r.result.nods[k], f"{r.result.share[k]:.4f}", f"{r.result.shifted[k]:.4f}", f"{r.result.p[k]:.4f}",
                     f"{r.result.pooled_p:.4f}", f"{r.speed[k]:.3f}")
                csv.append(",".join(str(x) for x in v))
    atomic_write_text(output / "listening.csv", "\n".join(csv) + "\n")
    first = runs_by_model[names[0]][0]
    c = first.conversation
    wait = first.first.get("not listening")
    if wait is None:  # (--no-levels: the not-listening head was not made)
        from ..synthesis import synthesize

        wait = synthesize(c.own, loaded[names[0]], seed=seed_list[0], hear=c.heard, listening=0)[0]
    conversation_figure(c, first.first["listening"], wait, first.cues, first.nods["listening"][0],
                        output / "listening_conversation.png")
    md = ("# Listening: nods read from the motion against cues read by Praat\n\n"
          f"Conversations: {', '.join(sorted({f'{x.name} ({x.voices})' for x in convs}))}; conditions "
          f"{', '.join(conds)}; seeds {', '.join(map(str, seed_list))}; listening {listening:g}.\n\n" + table +
          "\nLive layer = offline layer:\n\n" + "\n".join(streams) + "\n\n![a conversation](listening_conversation.png)\n")
    atomic_write_text(output / "listening.md", md)
    console.print(table, highlight=False, soft_wrap=True)
    console.print("\n".join(streams), highlight=False, soft_wrap=True)
    console.print(f"report: {output / 'listening.md'}", highlight=False)
