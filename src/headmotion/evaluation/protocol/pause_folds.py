"""Cut one long take into evaluation folds at its pauses (the ZEGGS take in
4–6 folds at pauses).

The seeds evaluate on corpora of many recordings (thesis §5.9 leave-one-recording-out); a single
long take — the one mocap recording with speech we have — has to be cut before it can be
cross-validated.  Cutting in the middle of a pause keeps every utterance whole and puts no speech
on both sides of a fold boundary.  Chosen here (the seeds are silent):

* candidate cuts are the middles of the non-speech runs at least ``min_pause_s`` long of
  :func:`headmotion.features.vad.speaking_mask` at the motion's rate, not touching either end;
* for ``n`` folds, cut ``k`` (k = 1…n−1) goes to the candidate nearest ``k·T/n`` that leaves at
  least ``min_fold_s`` seconds since the previous cut and before the end (greedy, in order);
* if a take has too few pauses for ``n`` folds it gets as many as it can (≥ 2), and
  :func:`split_corpus_at_pauses` says so in its warnings; a take with no usable pause raises.

Each part becomes a :class:`~headmotion.corpus.Recording` ``<id>_p<i>`` of the same speaker, so
the ordinary ``loo`` protocol (leave one recording of the speaker out) is leave-one-fold-out.

Library considered: scikit-learn's ``TimeSeriesSplit`` (index blocks of equal size, blind to where
the speech is); the cut choice is a few lines here.
"""

from __future__ import annotations

import numpy as np

from ...corpus import Corpus, Recording
from ...errors import ParameterError

#: shortest non-speech run (s) whose middle may be a cut
MIN_PAUSE_S = 0.3
#: shortest fold (s)
MIN_FOLD_S = 5.0


def pause_cut_candidates(speech_mask, *, fps: float, min_pause_s: float = MIN_PAUSE_S) -> np.ndarray:
    """Frame indices of the middles of the non-speech runs ≥ ``min_pause_s`` inside the take."""
    from ...features.vad import runs as _runs

    s = np.asarray(speech_mask, bool)
    n = max(1, int(round(min_pause_s * fps)))
    return np.array([(a + b) // 2 for a, b in _runs(~s) if b - a >= n and a > 0 and b < len(s)], dtype=int)


def choose_cuts(candidates, n_frames: int, n_folds: int, *, fps: float, min_fold_s: float = MIN_FOLD_S) -> list[int]:
    """Fold boundaries ``[0, c1, …, T]`` (see the module docstring); fewer than ``n_folds`` folds
    when the candidates do not allow that many."""
    if n_folds < 2:
        raise ParameterError(f"folds at pauses: need at least 2 folds; got {n_folds}")
    cands = np.sort(np.asarray(candidates, dtype=int))
    gap = int(round(min_fold_s * fps))
    cuts = [0]
    for k in range(1, n_folds):
        target = k * n_frames / n_folds
        ok = cands[(cands - cuts[-1] >= gap) & (n_frames - cands >= gap)]
        if len(ok) == 0:
            break
        c = int(ok[np.argmin(np.abs(ok - target))])
        if c <= cuts[-1]:
            continue
        cuts.append(c)
    cuts.append(int(n_frames))
    return cuts


def split_at_pauses(recording: Recording, n_folds: int, *, min_pause_s: float = MIN_PAUSE_S,
                    min_fold_s: float = MIN_FOLD_S) -> list[Recording]:
    """The recording cut at pauses into (up to) ``n_folds`` parts ``<id>_p0``, ``<id>_p1``, …"""
    from ...features.vad import speaking_mask

    m = recording.motion
    fps = float(m.fps)
    mask = speaking_mask(recording.audio, fps=fps, n_frames=len(m))
    cuts = choose_cuts(pause_cut_candidates(mask, fps=fps, min_pause_s=min_pause_s), len(m), n_folds, fps=fps,
                       min_fold_s=min_fold_s)
    if len(cuts) < 3:
        raise ParameterError(
            f"recording {recording.id!r} ({len(m) / fps:.1f} s) has no pause ≥ {min_pause_s:g} s that leaves "
            f"two folds of ≥ {min_fold_s:g} s; expected a longer take with pauses")
    out = []
    # the parts are slices of an aligned recording: not re-aligned, so no frame is lost at a cut
    for i, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        last = i == len(cuts) - 2
        sp = None if recording.speaking is None else recording.speaking[a:b]
        out.append(Recording(id=f"{recording.id}_p{i}", speaker=recording.speaker, task=recording.task,
                             audio=recording.audio.slice_seconds(a / fps, None if last else b / fps),
                             motion=m.slice_frames(a, b), speaking=sp))
    return out


def split_corpus_at_pauses(corpus: Corpus, n_folds: int, *, min_pause_s: float = MIN_PAUSE_S,
                           min_fold_s: float = MIN_FOLD_S) -> tuple[Corpus, list[str]]:
    """Every recording of ``corpus`` cut at its pauses; returns the new in-memory corpus and
    warnings (recordings that gave fewer folds than asked)."""
    recs: list[Recording] = []
    warns: list[str] = []
    for rec in corpus:
        parts = split_at_pauses(rec, n_folds, min_pause_s=min_pause_s, min_fold_s=min_fold_s)
        if len(parts) < n_folds:
            warns.append(f"{rec.id}: only {len(parts)} folds at pauses (asked for {n_folds}): too few pauses "
                         f"≥ {min_pause_s:g} s leaving folds of ≥ {min_fold_s:g} s")
        recs += parts
    return Corpus(recs, sample_rate=corpus.sample_rate), warns


__all__ = ["pause_cut_candidates", "choose_cuts", "split_at_pauses", "split_corpus_at_pauses", "MIN_PAUSE_S",
           "MIN_FOLD_S"]
