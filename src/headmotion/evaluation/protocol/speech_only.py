"""Cross-speaker coupling on speech with no recorded head: does a model follow a user's own voice?

Held-out speakers of a corpus share its microphones, rooms and recording styles; a user's
recording shares none of them, and it comes with no recorded head to compare against.  What can
still be measured is whether the motion a model makes is tied to *its own* speech the way recorded
heads are tied to theirs (:mod:`..measures.cross_coupling`):

* the projections (speech ``f0e`` with ±6 frames of context ↔ head angles and absolute speeds)
  are fitted once on the corpus's recorded heads and speech;
* each model synthesises each speech file (or a degraded copy, :mod:`.degraded`) with each seed,
  exactly as ``headmotion synth`` does (:func:`headmotion.synthesis.synthesize`);
* the statistic is the correlation of the first canonical variates over the file — the motion's
  projection against the projection of the file's *clean* speech (a degraded copy changes what the
  model hears, not what was said), and its null the motion's bridge circularly shifted
  (:func:`..measures.chance.shift_null`, the calibrated test);
* per seed, the files are pooled as the evaluation pools them (mean excess, Stouffer's p), and over
  every seed and file together.

    >>> rows = speech_coupling(corpus, {"default": "default"}, {"jfk": audio}, seeds=[0, 1])
"""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from ...errors import ParameterError
from ...types import Audio
from ..measures import chance as C
from ..measures.cross_coupling import CrossSpeakerCCA, pooled
from .degraded import degrade

#: analysis rate of the speech features and the measure
FPS = 25.0


def speech_features(audio: Audio):
    from ...align import n_frames
    from ...features import extract

    return extract("f0e", audio, fps=FPS, n_frames=n_frames(len(audio.samples), audio.sample_rate, FPS))


def fit_projections(corpus) -> CrossSpeakerCCA:
    """The speech ↔ motion projections fitted on every recording of ``corpus`` (recorded heads)."""
    recs = list(corpus)
    if not recs:
        raise ParameterError("the corpus for the coupling projections holds no recording")
    return CrossSpeakerCCA().fit([r.motion for r in recs], [speech_features(r.audio) for r in recs])


def speech_coupling(corpus, systems: Mapping[str, object], speech: Mapping[str, Audio], *,
                    seeds: Sequence[int] = (0, 1, 2, 3), degradations: Sequence[str] = ("clean",),
                    n_shifts: int = C.DEFAULT_SHIFTS, projections: CrossSpeakerCCA | None = None,
                    progress: Callable | None = None) -> list[dict]:
    """Coupling of each system's motion to its own speech, per file, seed and degradation.

    Parameters
    ----------
    corpus : Corpus — recorded heads with their speech, for the projections (ignored with ``projections``)
    systems : name → model (a shipped name, a model file or a loaded Synthesizer)
    speech : name → Audio, the speech files (no head needed)
    seeds : synthesis seeds
    degradations : ``"clean"`` and names of :data:`.degraded.DEGRADATIONS`
    n_shifts : circular shifts of the null
    projections : a fitted :class:`CrossSpeakerCCA` (else fitted on ``corpus``)
    progress : callable ``(done, total, description)``, optional

    Returns
    -------
    list of dict — one row per (degradation, system, seed, file) with ``excess``, ``p``, ``score``;
    then the pooled rows (``file`` = ``"ALL"``) per (degradation, system, seed) and over every seed
    (``seed`` = ``"ALL"``)
    """
    from ...synthesis import load_model, synthesize

    if not speech:
        raise ParameterError("no speech files to synthesise from")
    cca = projections if projections is not None else fit_projections(corpus)
    feats = {name: speech_features(a) for name, a in speech.items()}
    models = {name: load_model(m) for name, m in systems.items()}
    rows, results = [], {}
    total, done = len(degradations) * len(models) * len(seeds) * len(speech), 0
    for deg in degradations:
        heard = {name: degrade(a, deg) for name, a in speech.items()}
        for sys_name, model in models.items():
            for seed in seeds:
                for i, (name, audio) in enumerate(heard.items()):
                    motion = synthesize(audio, model, seed=int(seed))[0]
                    r = cca.test(motion, feats[name], n_shifts=n_shifts, seed=i)
                    results.setdefault((deg, sys_name, seed), []).append(r)
                    rows.append({"degradation": deg, "system": sys_name, "seed": seed, "file": name,
                                 "excess": r.excess, "p": r.p_value, "score": r.score})
                    done += 1
                    if progress:
                        progress(done, total, f"{deg} {sys_name} seed {seed} {name}")
    for deg in degradations:
        for sys_name in models:
            every = []
            for seed in seeds:
                res = results[(deg, sys_name, seed)]
                every += res
                rows.append({"degradation": deg, "system": sys_name, "seed": seed, "file": "ALL",
                             **_pooled_row(res, n_shifts)})
            rows.append({"degradation": deg, "system": sys_name, "seed": "ALL", "file": "ALL",
                         **_pooled_row(every, n_shifts)})
    return rows


def _pooled_row(results, n_shifts: int) -> dict:
    p = pooled(results, n_shifts=n_shifts)
    return {"excess": p["excess"], "p": p["p"], "score": float(np.mean([r.score for r in results]))}


def pooled_table(rows: Sequence[dict]) -> str:
    """The pooled rows as a Markdown table: one line per degradation and system, the seeds side by side."""
    pooled_rows = [r for r in rows if r["file"] == "ALL"]
    seeds = [s for s in dict.fromkeys(r["seed"] for r in pooled_rows) if s != "ALL"]
    head = "| degradation | system | " + " | ".join(f"seed {s}: excess (p)" for s in seeds) + " | all seeds |"
    lines = [head, "|" + "---|" * (3 + len(seeds))]
    keys = list(dict.fromkeys((r["degradation"], r["system"]) for r in pooled_rows))
    for deg, sys_name in keys:
        cells = {r["seed"]: f"{r['excess']:+.3f} ({r['p']:.3g})" for r in pooled_rows
                 if r["degradation"] == deg and r["system"] == sys_name}
        lines.append(f"| {deg} | {sys_name} | " + " | ".join(cells[s] for s in seeds) + f" | {cells['ALL']} |")
    return "\n".join(lines) + "\n"


__all__ = ["speech_coupling", "fit_projections", "pooled_table", "speech_features", "FPS"]
