"""Work spread over joblib processes or a Dask cluster: one task per item, results in order.

:func:`run_map` runs ``[fn(item) for item in items]`` serially, with joblib (``n_jobs``) or on a
Dask cluster (``scheduler`` = address or ``distributed.Client``); :func:`dask_client` opens the
connection.  Used for cross-validation folds, per-recording measures
(:mod:`headmotion.evaluation.protocol.parallel`) and the corpus feature cache
(:mod:`headmotion.feature_cache`).

On a cluster, the large arrays the items hold (a loaded corpus's audio and motion) are sent to the
workers once and shared by the tasks that use them (``client.scatter``), instead of once inside every
task: the folds of a cross-validation hold most of the same recordings, and without this each fold's
task carried them all again.  An item is pickled with its arrays of at least :data:`SHARED_BYTES`
replaced by references (``pickle``'s persistent IDs); a worker reads it back with the arrays Dask
gave it.  Those arrays are shared by the worker's tasks: read them, never write them.

Libraries considered: joblib (local processes) and dask.distributed (clusters) do the scheduling;
``dask.bag`` would add nothing over ``Client.map`` for one task per item.
"""

from __future__ import annotations

import contextlib
import functools
import io
import pickle
from typing import Any, Callable, Sequence

import numpy as np

from .errors import MissingDependencyError

#: arrays of at least this many bytes travel to a cluster once, shared by the tasks that hold them
SHARED_BYTES = 1 << 16


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

            blobs, keys, arrays = _by_reference(items)
            if arrays:
                # one future per array, Dask moving each where it is used; under keys of their own
                # (a list, hash=False): another call's release of the same arrays cannot take them away
                shared = dict(zip(arrays, client.scatter(list(arrays.values()), hash=False)))
                futures = [client.submit(_call_by_reference, blob, fn=fn, arrays={k: shared[k] for k in ks},
                                         pure=False)
                           for blob, ks in zip(blobs, keys)]
            else:
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


@functools.lru_cache(maxsize=1)
def _array_pickler_class() -> type:
    """The pickler of an item with its large arrays left out: each becomes ``("array", key)`` and
    goes into the pickler's ``arrays``.  cloudpickle's (Dask's own) when present, for items holding
    lambdas; made once, on the first cluster run."""
    try:
        from cloudpickle import CloudPickler as base
    except ImportError:  # pragma: no cover - dask.distributed depends on cloudpickle
        base = pickle.Pickler

    class ArrayPickler(base):
        def __init__(self, file, arrays: dict):
            super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
            self.arrays = arrays

        def persistent_id(self, obj):
            if type(obj) is np.ndarray and obj.nbytes >= SHARED_BYTES:
                key = f"array-{id(obj):x}"  # kept in ``arrays``, so alive: its id names no other
                self.arrays.setdefault(key, obj)
                return ("array", key)
            return None

    return ArrayPickler


class _ArrayUnpickler(pickle.Unpickler):
    def __init__(self, file, arrays: dict):
        super().__init__(file)
        self.arrays = arrays

    def persistent_load(self, pid):
        kind, key = pid
        if kind != "array" or key not in self.arrays:
            raise pickle.UnpicklingError(f"unknown array reference {pid!r}")
        return self.arrays[key]


def _by_reference(items: Sequence) -> tuple[list[bytes], list[list[str]], dict[str, np.ndarray]]:
    """Each item pickled without its large arrays, the keys of the arrays each one holds, and
    those arrays (each once) by key."""
    pickler = _array_pickler_class()
    arrays: dict[str, np.ndarray] = {}
    blobs, keys = [], []
    for it in items:
        buf = io.BytesIO()
        mine: dict[str, np.ndarray] = {}
        pickler(buf, mine).dump(it)
        blobs.append(buf.getvalue())
        keys.append(list(mine))
        arrays.update(mine)
    return blobs, keys, arrays


def _call_by_reference(blob: bytes, *, fn: Callable, arrays: dict):
    """``fn(item)`` on a worker, the item read back with the arrays Dask gave the task."""
    return fn(_ArrayUnpickler(io.BytesIO(blob), arrays).load())


__all__ = ["dask_client", "run_map", "SHARED_BYTES"]
