"""Corpus-wide work spread over joblib or a Dask cluster (folds *and* corpus-wide
feature extraction run on ``--scheduler ADDRESS``).

* :func:`run_map` — ``[fn(item) for item in items]`` in order, serially, with joblib
  (``n_jobs``) or on a Dask cluster (``scheduler`` = address or ``distributed.Client``); used for
  the cross-validation folds and for everything done per recording.
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

import contextlib
import zlib
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..corpus import Corpus
from ..errors import MissingDependencyError


# -- scheduling ----------------------------------------------------------------------------------
@contextlib.contextmanager
def dask_client(scheduler):
    """A ``distributed.Client`` for ``scheduler`` (an address, or a Client used as is and left
    open); ``None`` yields ``None``."""
    if scheduler is None:
        yield None
        return
    try:
        from distributed import Client
    except ImportError as exc:
        raise MissingDependencyError("--scheduler needs dask.distributed: pip install 'dask[distributed]'") from exc
    if isinstance(scheduler, Client):
        yield scheduler
        return
    client = Client(scheduler)
    try:
        yield client
    finally:
        client.close()


def run_map(fn: Callable, items: Sequence, *, n_jobs: int = 1, scheduler=None,
            progress: Callable | None = None, describe: Callable[[Any], str] | None = None) -> list:
    """``[fn(item) for item in items]``, in the order of ``items``.

    Parameters
    ----------
    fn : picklable callable (a module-level function)
    items : sequence of picklable arguments
    n_jobs : joblib processes (``-1`` = all cores); ignored when ``scheduler`` is given
    scheduler : Dask scheduler address (``tcp://host:8786``) or ``distributed.Client``
    progress : ``progress(done, total, description)``, optional
    describe : ``describe(item) -> str`` for the progress description
    """
    items = list(items)
    total = len(items)
    desc = describe or (lambda _item: "")
    if scheduler is not None:
        with dask_client(scheduler) as client:
            from distributed import as_completed

            futures = client.map(fn, items, pure=False)
            index = {f.key: i for i, f in enumerate(futures)}
            out: list = [None] * total
            for done, fut in enumerate(as_completed(futures), 1):
                i = index[fut.key]
                out[i] = fut.result()
                if progress:
                    progress(done, total, desc(items[i]))
            return out
    if n_jobs == 1 or total <= 1:
        out = []
        for i, it in enumerate(items):
            out.append(fn(it))
            if progress:
                progress(i + 1, total, desc(it))
        return out
    from joblib import Parallel, delayed

    out = []
    gen = Parallel(n_jobs=n_jobs, return_as="generator")(delayed(fn)(it) for it in items)
    for i, res in enumerate(gen):
        out.append(res)
        if progress:
            progress(i + 1, total, desc(items[i]))
    return out


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
