"""Cross-validation folds (thesis §5.9 leave-one-recording-out; paper §4.1 train / valid / test split;
leaving speakers out).

:func:`make_folds` gives ``(fold name, train, test, other speakers)`` for a protocol:

``"loo"`` (thesis §5.9)
    One fold per recording: the model is trained on the same speaker's other recordings.
``"split"`` (paper §4.1)
    One fold per speaker: train on ``train`` (and ``valid``, labelled, for systems that stop
    early), test on ``test``; the split comes from the manifest or
    :func:`headmotion.corpus.paper_split`.
``"speakers"`` (leave speakers out; the seeds are silent — chosen here to compare systems on
held-out speakers)
    The speakers, in a seeded random order, are dealt round-robin into ``speaker_folds`` groups
    (:func:`speaker_groups`; 0 = one group per speaker: leave-one-speaker-out); each fold trains on
    the other groups' recordings and tests on its group's, so no held-out speaker is seen in
    training.
``"sources"`` (leave sources out)
    One fold per source of the corpus (the manifest's ``source`` column: a dataset, a channel, a
    studio): each fold trains on every other source's recordings and tests on the source's own.
    Speakers held out by ``"speakers"`` share microphones, rooms, languages and recording styles
    with the library's; a held-out source shares none of them, as a user's own voice does not.

A single long take is cut into recordings at its pauses first (:mod:`.pause_folds`); ``loo`` on
the parts is then leave-one-fold-out.

Library considered: scikit-learn's ``LeaveOneGroupOut`` (the splits are one line here, and it knows
nothing of recordings held as lazy manifest entries).
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from ...corpus import Corpus, leave_one_out, paper_split
from ...errors import ParameterError


def _with_split(corpus: Corpus, idx: Sequence[int], split: dict[str, str]) -> Corpus:
    """Subset of ``corpus`` whose recordings carry the given split labels."""
    if corpus.root is not None:
        entries = [dataclasses.replace(corpus.entries[i], split=split.get(corpus.entries[i].recording)) for i in idx]
        return Corpus(root=corpus.root, entries=entries, sample_rate=corpus.sample_rate)
    return Corpus([dataclasses.replace(corpus[i], split=split.get(corpus[i].id)) for i in idx],
                  sample_rate=corpus.sample_rate)


def speaker_groups(speakers: Sequence[str], n_folds: int = 0, *, seed: int = 0) -> list[list[str]]:
    """The speakers in a seeded random order dealt round-robin into ``n_folds`` groups (0 or ≥ the
    number of speakers: one group per speaker)."""
    spk = sorted(set(speakers))
    if n_folds < 0:
        raise ParameterError(f"speaker folds must be ≥ 0; got {n_folds}")
    k = len(spk) if n_folds == 0 else min(n_folds, len(spk))
    order = [spk[i] for i in np.random.default_rng(seed).permutation(len(spk))]
    return [sorted(order[i::k]) for i in range(k)]


def make_folds(corpus: Corpus, protocol: str = "loo", *, seed: int = 0,
               speaker_folds: int = 0) -> list[tuple[str, Corpus, Corpus, Corpus | None]]:
    """``(fold name, train, test, other speakers)`` for ``protocol`` ``"loo"``, ``"split"``,
    ``"dataset"`` (the corpus's own split column: one fold, train + valid against test),
    ``"speakers"`` (``speaker_folds`` groups; 0 = leave-one-speaker-out) or ``"sources"`` (one fold
    per source)."""
    entries = corpus.entries
    def others_of(spk):
        idx = [i for i, e in enumerate(entries) if e.speaker != spk]
        return corpus.subset(idx) if idx else None
    folds = []
    if protocol == "loo":
        for rid, train, test in leave_one_out(corpus, per_speaker=True):
            spk = test.entries[0].speaker
            folds.append((rid, train, test, others_of(spk)))
        if not folds:
            raise ParameterError("leave-one-out needs a speaker with at least 2 recordings")
    elif protocol == "split":
        split = paper_split(corpus, seed=seed)
        for spk in corpus.speakers:
            tr = [i for i, e in enumerate(entries) if e.speaker == spk and split.get(e.recording) in ("train", "valid")]
            te = [i for i, e in enumerate(entries) if e.speaker == spk and split.get(e.recording) == "test"]
            if not tr or not te:
                continue
            folds.append((spk, _with_split(corpus, tr, split), _with_split(corpus, te, split), others_of(spk)))
        if not folds:
            raise ParameterError("the split protocol found no speaker with both train and test recordings")
    elif protocol == "dataset":
        from .dataset_split import dataset_split_folds

        folds = dataset_split_folds(corpus)
    elif protocol == "sources":
        folds = _source_folds(corpus)
    elif protocol == "speakers":
        groups = speaker_groups(corpus.speakers, speaker_folds, seed=seed)
        if len(groups) < 2:
            raise ParameterError(f"leaving speakers out needs at least 2 speakers; the corpus has {len(groups)}")
        for g in groups:
            te = [i for i, e in enumerate(entries) if e.speaker in g]
            tr = [i for i, e in enumerate(entries) if e.speaker not in g]
            name = g[0] if len(g) == 1 else f"{g[0]}+{len(g) - 1}"
            folds.append((name, corpus.subset(tr), corpus.subset(te), corpus.subset(tr)))
    else:
        raise ParameterError(f"protocol must be 'loo', 'split', 'dataset', 'speakers' or 'sources'; got {protocol!r}")
    return folds


def source_of(entry) -> str | None:
    """The source of a manifest entry (its ``source`` column), or None."""
    return getattr(entry, "source", None)


def _source_folds(corpus: Corpus) -> list:
    """One fold per source: train on the other sources, test on this one's recordings."""
    entries = corpus.entries
    missing = [e.recording for e in entries if not source_of(e)]
    if missing:
        raise ParameterError(f"leaving sources out needs a 'source' for every recording (a column of corpus.csv); "
                             f"{len(missing)} have none, e.g. {missing[0]!r}")
    sources = sorted({source_of(e) for e in entries})
    if len(sources) < 2:
        raise ParameterError(f"leaving sources out needs at least 2 sources; the corpus has {len(sources)}")
    folds = []
    for src in sources:
        te = [i for i, e in enumerate(entries) if source_of(e) == src]
        tr = [i for i, e in enumerate(entries) if source_of(e) != src]
        folds.append((src, corpus.subset(tr), corpus.subset(te), corpus.subset(tr)))
    return folds


def longest_held_out(folds) -> str:
    """The held-out recording with the longest motion (the first of equals).  Recordings of an
    on-disk corpus are not loaded for this (only their motion files are read), so the fold tasks
    still ship lazy manifest entries to the workers."""
    from ...errors import HeadMotionError
    from ...io import load_motion

    best, best_s = None, -1.0
    for _, _, test, _ in folds:
        for i, e in enumerate(test.entries):
            try:
                m = test[i].motion if test.root is None else load_motion(test.root / e.motion)
                secs = len(m) / float(m.fps)
            except HeadMotionError:  # the fold will report it
                secs = 0.0
            if best is None or secs > best_s:
                best, best_s = e.recording, secs
    return best



__all__ = ["make_folds", "speaker_groups", "longest_held_out", "source_of"]
