"""The dataset's own split as one evaluation fold (``evaluate --protocol dataset``).

Public corpora ship a train / validation / test split (BEAT2's ``train_test_split.csv``, kept by
``corpus import-dataset`` in the manifest's ``split`` column); results in the field are reported on
its test recordings.  This protocol trains each system once, on every ``train`` and ``valid``
recording of all speakers (the networks keep ``valid`` for early stopping, as the labels say), and
scores it on every ``test`` recording.  The per-speaker paper protocol is ``split``
(:func:`headmotion.evaluation.protocol.protocols.make_folds`).
"""

from __future__ import annotations

import dataclasses

from ...corpus import Corpus
from ...errors import ParameterError


def dataset_split_folds(corpus: Corpus) -> list[tuple[str, Corpus, Corpus, Corpus | None]]:
    """One fold ``("dataset split", train, test, train)`` from the manifest's ``split`` column.

    Parameters
    ----------
    corpus : Corpus whose manifest labels recordings ``train``, ``valid`` or ``test``

    Returns
    -------
    list with one ``(fold name, training corpus (train + valid, labels kept), test corpus, the
    other speakers' corpus for systems that need one: the training corpus)``

    Raises
    ------
    ParameterError
        when no recording has a split label, or there are no test or no training recordings;
        recordings without a label are named (they would be silently dropped).
    """
    entries = corpus.entries
    labelled = [e for e in entries if e.split]
    where = f" of {corpus.root}" if corpus.root is not None else ""
    if not labelled:
        raise ParameterError(
            f"the corpus{where} has no split column (corpus.csv 'split': train, valid or test per recording); "
            "--protocol dataset evaluates on a dataset's own test recordings; without them use --protocol split "
            "(per speaker, 60/20/20 %) or loo")
    unlabelled = [e.recording for e in entries if not e.split]
    if unlabelled:
        raise ParameterError(
            f"{len(unlabelled)} recording(s){where} have no split label (e.g. {unlabelled[:3]}); label every "
            "recording train, valid or test in corpus.csv, or leave them out with --exclude")
    tr = [i for i, e in enumerate(entries) if e.split in ("train", "valid")]
    te = [i for i, e in enumerate(entries) if e.split == "test"]
    if not te:
        raise ParameterError(f"the corpus{where} has no recording labelled 'test' in its split column")
    if not tr:
        raise ParameterError(f"the corpus{where} has no recording labelled 'train' or 'valid' in its split column")
    train, test = _labelled(corpus, tr), _labelled(corpus, te)
    return [("dataset split", train, test, train)]


def _labelled(corpus: Corpus, idx: list[int]) -> Corpus:
    """The recordings ``idx`` with their split labels (a corpus on disk stays on disk)."""
    if corpus.root is not None:
        return corpus.subset(idx)
    return Corpus([dataclasses.replace(corpus[i], split=corpus.entries[i].split) for i in idx],
                  sample_rate=corpus.sample_rate)


__all__ = ["dataset_split_folds"]
