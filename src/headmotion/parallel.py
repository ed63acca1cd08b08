"""Work spread over joblib processes or a Dask cluster: one task per item, results in order.

:func:`run_map` runs ``[fn(item) for item in items]`` serially, with joblib (``n_jobs``) or on a
Dask cluster (``scheduler`` = address or ``distributed.Client``); :func:`dask_client` opens the
connection.  Used for cross-validation folds, per-recording measures
(:mod:`headmotion.evaluation.protocol.parallel`) and the corpus feature cache
(:mod:`headmotion.feature_cache`).

Libraries considered: joblib (local processes) and dask.distributed (clusters) do the scheduling;
``dask.bag`` would add nothing over ``Client.map`` for one task per item.
"""

from __future__ import annotations

import contextlib
from typing import Any, Callable, Sequence

from .errors import MissingDependencyError


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



__all__ = ["dask_client", "run_map"]
