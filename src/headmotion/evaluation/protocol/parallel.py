"""Corpus-wide work spread over joblib or a Dask cluster (folds *and* corpus-wide
feature extraction run on ``--scheduler ADDRESS``).

* :func:`run_map` (:mod:`headmotion.parallel`) — ``[fn(item) for item in items]`` in order,
  serially, with joblib (``n_jobs``) or on a Dask cluster (``scheduler`` = address or
  ``distributed.Client``); used for the cross-validation folds and for everything done per recording.
* :func:`map_recordings` — :func:`run_map` over the recordings of a corpus.  A recording of an
  on-disk corpus that is not loaded yet travels as its manifest entry (a few hundred bytes) and is
  read by the worker, so a cluster with the corpus on shared storage never ships audio.
* :func:`sub_seed` — the seed of one task from the global seed and names.

What runs on it (paper Table 1, corpus features) is in :mod:`.feature_table`.

Determinism: every result depends only on the recording and the seed, never on which worker ran
it, so serial, joblib and Dask runs are identical (tested with a ``LocalCluster``).

Libraries considered: joblib (local processes) and dask.distributed (clusters) do the scheduling;
``dask.bag`` would add nothing over ``Client.map`` for one task per recording.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...corpus import Corpus
from ...parallel import dask_client, run_map  # noqa: F401  (re-exported: the folds and the feature table use them)


def _one_recording_corpora(corpus: Corpus) -> list[Corpus]:
    """One single-recording corpus per recording (lazy entries stay lazy)."""
    return [corpus.subset([i]) for i in range(len(corpus))]


def map_recordings(fn: Callable, corpus: Corpus, *, args: tuple = (), n_jobs: int = 1, scheduler=None,
                   progress: Callable | None = None) -> list:
    """``[fn(recording, *args) for recording in corpus]`` with :func:`run_map` (order kept)."""
    items = [_RecordingCall(c, fn, tuple(args)) for c in _one_recording_corpora(corpus)]
    return run_map(_call_on_recording, items, n_jobs=n_jobs, scheduler=scheduler, progress=progress,
                   describe=lambda it: it.corpus.entries[0].recording)


@dataclass(frozen=True)
class _RecordingCall:
    """One task of :func:`map_recordings` (a dataclass, not a tuple: Dask reads tuples that start
    with a callable as tasks)."""

    corpus: Corpus  # one recording, lazy when the corpus is on disk
    fn: Callable
    args: tuple


def _call_on_recording(item: _RecordingCall):
    return item.fn(item.corpus[0], *item.args)


def sub_seed(*parts) -> int:
    """A 32-bit seed from the global seed and names (stable across processes, unlike hash())."""
    ints = [p if isinstance(p, int) else zlib.crc32(str(p).encode()) for p in parts]
    return int(np.random.SeedSequence(ints).generate_state(1)[0])


__all__ = ["run_map", "map_recordings", "dask_client", "sub_seed"]
