"""A seeded subsample of a corpus's recordings up to a duration budget, for training in bounded
memory (``docs/decisions/bounded-training.md``).

The template-warping systems and le2012 fit Gaussian mixtures and HMMs whose few hundred
parameters per axis are estimated from change points or frames; their training gathers every
training vector in memory.  On a corpus longer than their budget (``max_train_hours``) they learn
from the recordings :func:`budget_subset` picks: whole recordings (so segments, contexts and the
template sequences stay intact), drawn in a seeded random order taking each speaker in turn (so
every speaker is represented in proportion while it has recordings left), until the budget is
reached.  A corpus within the budget is used whole, in its own order: nothing changes for it.
The DNN systems use the same draw for their post-processing tables (:mod:`.dnn.streamed`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import ParameterError

#: the GMM/HMM systems' default training budget (``max_train_hours``)
DEFAULT_TRAIN_HOURS = 4.0


def recording_seconds(corpus, index: int) -> float:
    """Duration in seconds of recording ``index``: read from the speech file's header for a corpus on
    disk (:func:`headmotion.io.audio_blocks.audio_duration`, no decoding), else the loaded
    recording's."""
    root = getattr(corpus, "root", None)
    if root is not None:
        from ..io.audio_blocks import audio_duration

        seconds = audio_duration(Path(root) / corpus.entries[index].audio)
        if np.isfinite(seconds):
            return seconds
    return float(corpus[index].duration)


def budget_subset(corpus, max_seconds: float | None, *, seed: int = 0, indices=None) -> list[int]:
    """Indices (into ``corpus``) of the recordings to train on within ``max_seconds`` of speech.

    Parameters
    ----------
    corpus : Corpus (or a sequence of recordings)
    max_seconds : float or None — the budget; None or ``inf``: every recording
    seed : the draw's seed
    indices : the candidate recordings (default: all)

    Returns
    -------
    list of int — all candidates in their order when they fit the budget; else the drawn ones,
    in corpus order.  At least one recording is always kept.
    """
    cand = list(range(len(corpus))) if indices is None else [int(i) for i in indices]
    if max_seconds is None or math.isinf(float(max_seconds)) or not cand:
        return cand
    if not float(max_seconds) > 0:
        raise ParameterError(f"a training budget must be a positive number of hours; got {max_seconds!r} s")
    seconds = {i: recording_seconds(corpus, i) for i in cand}
    if sum(seconds.values()) <= float(max_seconds):
        return cand
    rng = np.random.default_rng(int(seed))
    speaker = _speakers(corpus, cand)
    queues: dict[str, list[int]] = {}
    for i in (cand[k] for k in rng.permutation(len(cand))):
        queues.setdefault(speaker[i], []).append(i)
    order = [s for s in sorted(queues)]
    order = [order[k] for k in rng.permutation(len(order))]
    chosen, total = [], 0.0
    while total < float(max_seconds) and any(queues.values()):
        for s in order:
            if queues[s] and total < float(max_seconds):
                i = queues[s].pop(0)
                chosen.append(i)
                total += seconds[i]
    return sorted(chosen)


def _speakers(corpus, cand) -> dict[int, str]:
    entries = getattr(corpus, "entries", None)
    if entries is not None:
        return {i: str(entries[i].speaker) for i in cand}
    return {i: str(corpus[i].speaker) for i in cand}


def check_hours(system) -> None:
    """Raise ParameterError unless ``system.max_train_hours`` is None or a positive number."""
    h = system.max_train_hours
    if h is not None and (isinstance(h, bool) or not isinstance(h, (int, float, np.integer, np.floating))
                          or not h > 0):
        raise ParameterError(f"the 'max_train_hours' parameter of {system.name} must be a positive number of "
                             f"hours or None (every recording); got {h!r}")


def training_recordings(system, corpus) -> list:
    """The recordings ``system`` trains on: all of ``corpus`` within ``system.max_train_hours``, else
    the draw of :func:`budget_subset` seeded with ``system.random_state``; records the draw in
    ``system.train_subsample_`` (None when every recording is used)."""
    hours = system.max_train_hours
    keep = budget_subset(corpus, None if hours is None else float(hours) * 3600.0,
                         seed=int(system.random_state))
    system.train_subsample_ = (None if len(keep) == len(corpus) else
                               {"recordings": len(keep), "of": len(corpus), "max_train_hours": float(hours)})
    return [corpus[i] for i in keep]


def corpus_summary(system, corpus) -> dict | None:
    """``corpus.summary()`` with the draw of :func:`training_recordings` as ``trained_on`` (when
    ``system`` trained on a subsample); None for a corpus without a summary."""
    summary = corpus.summary() if hasattr(corpus, "summary") else None
    if summary is not None and getattr(system, "train_subsample_", None) is not None:
        summary["trained_on"] = system.train_subsample_
    return summary


__all__ = ["DEFAULT_TRAIN_HOURS", "budget_subset", "recording_seconds", "check_hours", "training_recordings",
           "corpus_summary"]
