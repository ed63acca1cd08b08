"""One BLAS thread in a process that streams head motion.

A live stream decides a move every few frames from a handful of matrix–vector products over the
motion library (about 21 000 × 30 for the shipped model, :mod:`headmotion.systems.motion_match`).
Products that small gain nothing from BLAS threads, and OpenBLAS's threads keep spinning after each
call: with its default two threads the shipped stream model costs 0.8–0.9 ms of CPU per 10 ms audio
chunk, with one thread 0.24–0.25 ms (``python benchmarks/run.py --only stream``; the wall time of
each push is the same).  A server carrying many streams, or an agent whose audio loop runs every
10 ms, wants the cores for streams, not for spinning threads.

:func:`one_blas_thread` is called by the live core (:class:`headmotion.live.core.HeadMotionCore`),
which every live path runs: ``headmotion stream``, ``headmotion serve``'s ``/v1/stream`` (and
``view --live``, the avatar page) and the agent integrations.  A user who set the thread count themselves (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``)
keeps it.
"""

from __future__ import annotations

import os

#: environment variables with which a user sets BLAS threads themselves (then left as they are)
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


_done = False  # set once in a process (a stream opened per connection need not ask again)


def one_blas_thread(environ=None) -> bool:
    """Limit this process's BLAS libraries to one thread, unless the user set a count in
    ``environ`` (default :data:`os.environ`; :data:`THREAD_VARIABLES`).  Returns whether the limit
    is set.  Once set, later calls return at once."""
    global _done
    if _done and environ is None:
        return True
    if any((os.environ if environ is None else environ).get(v) for v in THREAD_VARIABLES):
        return False
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
    _done = environ is None
    return True


__all__ = ["one_blas_thread", "THREAD_VARIABLES"]
