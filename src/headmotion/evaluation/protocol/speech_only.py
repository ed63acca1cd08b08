"""Cross-speaker coupling on speech with no recorded head: does a model follow a user's own voice?

Held-out speakers of a corpus share its microphones, rooms and recording styles; a user's
recording shares none of them, and it comes with no recorded head to compare against.  What can
still be measured is whether the motion a model makes is tied to *its own* speech the way recorded
heads are tied to theirs (:mod:`..measures.cross_coupling`):

* the projections (speech features with ±6 frames of context ↔ head angles and absolute speeds)
  are fitted once on the corpus's recorded heads and speech, once per *speech side*
  (:mod:`..measures.speech_sides`: Praat's ``f0e``, the project's own frame-by-frame reading, or
  energy alone), so that no model is scored only by the reading of the voice it makes itself;
* each model synthesises each speech file (or a degraded copy, :mod:`.degraded`) with each seed,
  exactly as ``headmotion synth`` does (:func:`headmotion.synthesis.synthesize`);
* the statistic is the correlation of the first canonical variates over the file — the motion's
  projection against the projection of the file's *clean* speech (a degraded copy changes what the
  model hears, not what was said), and its null the motion's bridge circularly shifted
  (:func:`..measures.chance.shift_null`, the calibrated test);
* per seed, the files are pooled as the evaluation pools them (mean excess, Stouffer's p), and over
  every seed and file together;
* a model with a *level* (:mod:`.levels`: the Praat-read library of a ``motion-match`` model) is
  given its ratio to it: its pooled excess over the level's, same side, degradation and seeds.

    >>> rows = speech_coupling(corpus, {"default": "default"}, {"jfk": audio}, seeds=[0, 1],
    ...                        sides=("praat", "own", "energy"))
"""


from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from ...errors import ParameterError
from ...types import Audio
from ..measures import chance as C
from ..measures.cross_coupling import CrossSpeakerCCA, pooled
from ..measures.speech_sides import DEFAULT_SIDE, parse_sides, sides_features
from .degraded import degrade
from .levels import ratio

#: analysis rate of the speech features and the measure
FPS = 25.0


def _n_frames(audio: Audio) -> int:
    from ...align import n_frames

    return n_frames(len(audio.samples), audio.sample_rate, FPS)


def speech_features(audio: Audio, side: str = DEFAULT_SIDE):
    """The speech features of one side (:mod:`..measures.speech_sides`) at the measure's 25 fps."""
    return sides_features(audio, (side,), fps=FPS, n_frames=_n_frames(audio))[side]


def fit_projections(corpus, side: str = DEFAULT_SIDE) -> CrossSpeakerCCA:
    """The speech ↔ motion projections of one speech side, fitted on every recording of ``corpus``
    (recorded heads)."""
    return fit_side_projections(corpus, (side,))[side]


def fit_side_projections(corpus, sides: Sequence[str]) -> dict[str, CrossSpeakerCCA]:
    """``{side: projections}`` fitted on every recording of ``corpus``, each side on its own
    features (each recording's audio read once)."""
    sides = parse_sides(sides)
    recs = list(corpus)
    if not recs:
        raise ParameterError("the corpus for the coupling projections holds no recording")
    feats = [sides_features(r.audio, sides, fps=FPS, n_frames=_n_frames(r.audio)) for r in recs]
    return {s: CrossSpeakerCCA().fit([r.motion for r in recs], [f[s] for f in feats]) for s in sides}


def _projections(corpus, projections, sides: tuple[str, ...]) -> dict[str, CrossSpeakerCCA]:
    if projections is None:
        return fit_side_projections(corpus, sides)
    if isinstance(projections, CrossSpeakerCCA):
        if len(sides) != 1:
            raise ParameterError(f"one fitted CrossSpeakerCCA scores one speech side; got sides {sides} "
                                 f"(give {{side: projections}})")
        return {sides[0]: projections}
    missing = [s for s in sides if s not in projections]
    if missing:
        raise ParameterError(f"no projections for the speech side(s) {missing}")
    return {s: projections[s] for s in sides}


def speech_coupling(corpus, systems: Mapping[str, object], speech: Mapping[str, Audio], *,
                    seeds: Sequence[int] = (0, 1, 2, 3), degradations: Sequence[str] = ("clean",),
                    n_shifts: int = C.DEFAULT_SHIFTS,
                    projections: CrossSpeakerCCA | Mapping[str, CrossSpeakerCCA] | None = None,
                    sides: Sequence[str] = (DEFAULT_SIDE,), levels: Mapping[str, str] | None = None,
                    progress: Callable | None = None) -> list[dict]:
    """Coupling of each system's motion to its own speech, per speech side, file, seed and degradation.

    Parameters
    ----------
    corpus : Corpus — recorded heads with their speech, for the projections (ignored with ``projections``)
    systems : name → model (a shipped name, a model file or a loaded Synthesizer)
    speech : name → Audio, the speech files (no head needed)
    seeds : synthesis seeds
    degradations : ``"clean"`` and names of :data:`.degraded.DEGRADATIONS`
    n_shifts : circular shifts of the null
    projections : fitted projections: one :class:`CrossSpeakerCCA` (one side) or ``{side: CCA}``;
        else fitted on ``corpus`` per side
    sides : the speech sides scored (:data:`~..measures.speech_sides.SPEECH_SIDES`); each motion is
        made once and scored under every side
    levels : system → the system (in ``systems``) that is its level (:mod:`.levels`); its pooled
        rows get ``ratio`` = excess / the level's excess (same side, degradation and seeds)
    progress : callable ``(done, total, description)``, optional

    Returns
    -------
    list of dict — one row per (side, degradation, system, seed, file) with ``excess``, ``p``,
    ``score``; then the pooled rows (``file`` = ``"ALL"``) per (side, degradation, system, seed) and
    over every seed (``seed`` = ``"ALL"``), with ``level`` (the level's name, ``""`` without) and
    ``ratio`` (nan without a level, or when the level is not above its null)
    """
    from ...synthesis import load_model, synthesize

    if not speech:
        raise ParameterError("no speech files to synthesise from")
    sides = parse_sides(sides)
    levels = dict(levels or {})
    unknown = sorted({k for k in levels if k not in systems} | {v for v in levels.values() if v not in systems})
    if unknown:
        raise ParameterError(f"levels name systems that are not evaluated: {unknown}")
    cca = _projections(corpus, projections, sides)
    feats = {name: sides_features(a, sides, fps=FPS, n_frames=_n_frames(a)) for name, a in speech.items()}
    models = {name: load_model(m) for name, m in systems.items()}
    rows, results = [], {}
    total, done = len(degradations) * len(models) * len(seeds) * len(speech), 0
    for deg in degradations:
        heard = {name: degrade(a, deg) for name, a in speech.items()}
        for sys_name, model in models.items():
            for seed in seeds:
                for i, (name, audio) in enumerate(heard.items()):
                    motion = synthesize(audio, model, seed=int(seed))[0]
                    for side in sides:
                        r = cca[side].test(motion, feats[name][side], n_shifts=n_shifts, seed=i)
                        results.setdefault((side, deg, sys_name, seed), []).append(r)
                        rows.append({"side": side, "degradation": deg, "system": sys_name, "seed": seed, "file": name,
                                     "excess": r.excess, "p": r.p_value, "score": r.score})
                    done += 1
                    if progress:
                        progress(done, total, f"{deg} {sys_name} seed {seed} {name}")
    return rows + _pooled_rows(results, sides, degradations, models, seeds, levels, n_shifts)


def _pooled_rows(results, sides, degradations, models, seeds, levels, n_shifts) -> list[dict]:
    """Pooled rows per seed and over every seed, then each system's ratio to its level."""
    out = []
    for side in sides:
        for deg in degradations:
            for sys_name in models:
                every = []
                for seed in seeds:
                    res = results[(side, deg, sys_name, seed)]
                    every += res
                    out.append({"side": side, "degradation": deg, "system": sys_name, "seed": seed, "file": "ALL",
                                **_pooled_row(res, n_shifts)})
                out.append({"side": side, "degradation": deg, "system": sys_name, "seed": "ALL", "file": "ALL",
                            **_pooled_row(every, n_shifts)})
    excess = {(r["side"], r["degradation"], r["system"], r["seed"]): r["excess"] for r in out}
    for r in out:
        lv = levels.get(r["system"], "")
        r["level"] = lv
        r["ratio"] = ratio(r["excess"], excess[(r["side"], r["degradation"], lv, r["seed"])]) if lv else float("nan")
    return out


def _pooled_row(results, n_shifts: int) -> dict:
    p = pooled(results, n_shifts=n_shifts)
    return {"excess": p["excess"], "p": p["p"], "score": float(np.mean([r.score for r in results]))}


def _ratio_cell(x: float) -> str:
    return f"{x:.2f}" if np.isfinite(x) else "–"


def pooled_table(rows: Sequence[dict]) -> str:
    """The pooled rows as a Markdown table: a block of lines per speech side, one line per
    degradation and system, the seeds side by side, then every seed pooled and, for a system with
    a level, its ratio to the level over every seed and per seed."""
    pooled_rows = [r for r in rows if r["file"] == "ALL"]
    seeds = [s for s in dict.fromkeys(r["seed"] for r in pooled_rows) if s != "ALL"]
    any_level = any(r.get("level") for r in pooled_rows)
    head = ("| speech side | degradation | system | " + " | ".join(f"seed {s}: excess (p)" for s in seeds)
            + " | all seeds |" + (" ratio to level | per seed |" if any_level else ""))
    lines = [head, "|" + "---|" * (4 + len(seeds) + (2 if any_level else 0))]
    keys = list(dict.fromkeys((r.get("side", DEFAULT_SIDE), r["degradation"], r["system"]) for r in pooled_rows))
    for side, deg, sys_name in keys:
        mine = {r["seed"]: r for r in pooled_rows
                if r.get("side", DEFAULT_SIDE) == side and r["degradation"] == deg and r["system"] == sys_name}
        cells = {s: f"{r['excess']:+.3f} ({r['p']:.3g})" for s, r in mine.items()}
        line = f"| {side} | {deg} | {sys_name} | " + " | ".join(cells[s] for s in seeds) + f" | {cells['ALL']} |"
        if any_level:
            if mine["ALL"].get("level"):
                line += (f" {_ratio_cell(mine['ALL']['ratio'])} | "
                         + "/".join(_ratio_cell(mine[s]["ratio"]) for s in seeds) + " |")
            else:
                line += " | |"
        lines.append(line)
    return "\n".join(lines) + "\n"


def files_table(rows: Sequence[dict], describe: Callable[[str], tuple[str, str]] | None = None,
                degradation: str = "clean") -> str:
    """Per file (its kind and language from ``describe(name) -> (kind, language)``): each system's
    excess averaged over the seeds, one cell per system with the sides' values ``a / b / c`` in
    the order of the rows, under ``degradation``."""
    per = [r for r in rows if r["file"] != "ALL" and r["degradation"] == degradation]
    if not per:
        return ""
    sides = list(dict.fromkeys(r.get("side", DEFAULT_SIDE) for r in per))
    systems = list(dict.fromkeys(r["system"] for r in per))
    files = list(dict.fromkeys(r["file"] for r in per))
    head = "| file | kind | language | " + " | ".join(systems) + " |"
    lines = [head, "|" + "---|" * (3 + len(systems))]
    for f in files:
        kind, lang = describe(f) if describe else ("–", "–")
        cells = []
        for s in systems:
            vals = [np.mean([r["excess"] for r in per if r["file"] == f and r["system"] == s
                             and r.get("side", DEFAULT_SIDE) == side]) for side in sides]
            cells.append(" / ".join(f"{v:+.2f}" for v in vals))
        lines.append(f"| {f} | {kind} | {lang} | " + " | ".join(cells) + " |")
    return (f"Mean excess over the seeds, {degradation}; each cell {' / '.join(sides)}.\n\n"
            + "\n".join(lines) + "\n")


__all__ = ["speech_coupling", "fit_projections", "fit_side_projections", "pooled_table", "files_table",
           "speech_features", "FPS"]
