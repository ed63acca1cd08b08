"""``headmotion adapt CORPUS|AUDIO MOTION… -o MINE.hmz [--base default|MODEL]``: a model adapted to
one speaker from their recordings (:mod:`headmotion.systems.adapt`), with its model card beside it."""

from __future__ import annotations

import time
from pathlib import Path
from typing import List, Optional

import typer

from ..errors import ParameterError
from .app import app, console, progress_bar


def card_text(model, corpus_dir, output: Path) -> str:
    """The model card of an adapted model: what it was adapted from, on what, and how to use it."""
    a = model.adapted_from_ or {}
    base_corpus = a.get("base_corpus") or {}
    c = model.corpus_summary_ or {}
    return "\n".join([
        f"# Model card: {output.stem} (motion-match, adapted)",
        "",
        f"- **Adapted from** the model `{a.get('base')}` "
        f"({base_corpus.get('recordings', '?')} recordings, {base_corpus.get('minutes', '?')} min) "
        f"to the speaker(s) {', '.join(c.get('speakers', [])) or '?'} of `{corpus_dir}`: "
        f"{a.get('recordings')} recordings, {a.get('speech_seconds')} s of speech with motion.",
        f"- **Library**: the base's recorded movements and the speaker's; the speaker's are preferred "
        f"(a base frame costs {a.get('base_cost')} more). Range, posture and the pose the speech asks "
        "for are fitted on the speaker's frames.",
        "- **Use**: `headmotion synth SPEECH -m " + output.name + " -o OUT.bvh` (`--amount` for more or "
        "less motion); `headmotion serve --models DIR` offers it by its file name.",
        "- **Licence**: the model holds the speaker's head motion and per-frame prosody (no audio, no "
        "video) and the base model's library: it carries the terms of the speaker's recordings and "
        "of the base model.",
        "",
    ])


@app.command()
def adapt(
    sources: List[Path] = typer.Argument(..., metavar="CORPUS | AUDIO MOTION ...", help="The speaker's recordings "
                                         "with motion: a corpus folder (from `headmotion corpus import`, `corpus "
                                         "from-video` or an imported dataset), or audio and motion files paired by "
                                         "stem (take1.wav take1.bvh …)."),
    output: Path = typer.Option(..., "-o", "--output", help="Model file to write (.hmz); its card goes beside it (.md)."),
    base: str = typer.Option("default", "--base", metavar="NAME|FILE", help="The model adapted: 'default', "
                             "'stream' or a motion-match model file."),
    base_cost: Optional[float] = typer.Option(None, "--base-cost", help="How strongly the speaker's own movements "
                                              "are preferred over the base's (default 2; 0: no preference)."),
    speaker: Optional[str] = typer.Option(None, "--speaker", help="A corpus folder: only this speaker's recordings; "
                                          "files: the speaker's name for the card."),
):
    """Adapt a model to a speaker from their recordings (at least 20 s of speech with motion; a
    minute or more is better): their movements join the model's and are preferred, and its range
    and posture follow theirs."""
    from ..corpus import Corpus, CorpusEntry
    from ..systems.adapt import BASE_COST
    from ..systems.adapt import adapt as adapt_model
    from .corpus_cmds import pair_by_stem

    if output.suffix.lower() != ".hmz":
        raise ParameterError(f"-o {output}: a model file must end in .hmz")
    folder = sources[0] if len(sources) == 1 else None
    if folder is not None and folder.is_file() and folder.name == "corpus.csv":  # the folder's manifest
        folder = folder.parent
    if folder is not None and folder.is_dir():
        c = Corpus.load(folder)
        if speaker is not None:
            c = c.filter(speaker=speaker)
        where = str(folder)
    elif folder is not None and not folder.exists():
        raise ParameterError(f"{folder}: no such corpus folder or file")
    else:  # audio and motion files: a corpus of them, read where they are
        who = speaker or "speaker"
        c = Corpus(root=Path.cwd(), entries=[CorpusEntry(stem, who, "speech", d["audio"].resolve(), d["motion"].resolve())
                            for stem, d in sorted(pair_by_stem(sources).items())])
        where = ", ".join(f.name for f in sources)
    t0 = time.perf_counter()
    with progress_bar("adapting") as update:
        model = adapt_model(c, base, base_cost=BASE_COST if base_cost is None else base_cost,
                            progress=lambda done, total, desc: update(done, total=total, description=desc),
                            name=where)
    out = model.save(output)
    card = out.with_suffix(".md")
    try:
        card.write_text(card_text(model, where, out), encoding="utf-8")
    except OSError:
        out.unlink(missing_ok=True)  # no model without its card
        raise
    a = model.adapted_from_
    console.print(f"adapted {base} to {a['recordings']} recording(s), {a['speech_seconds']:.1f} s of speech, in "
                  f"{time.perf_counter() - t0:.1f} s → {out} (card: {card})", highlight=False)
