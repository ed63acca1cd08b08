"""librosa imported, and each of its functions first used, under a lock that every process on the
machine shares, so that numba's on-disk cache of librosa's compiled functions is written by one
process at a time.

numba caches a ``guvectorize`` function (librosa's peak picking behind ``onset_detect``, its zero
crossings, its pitch interpolation) as two files, the kernel and its wrapper; when two processes
compile at once, each can write one of them with its own internal names, and every later process
that loads the pair crashes with a segmentation fault (numba issue 10128, open; seen when the
evaluation's worker processes started together in a fresh environment, and reproduced with six
plain ``librosa.onset.onset_detect`` processes started 0.4 s apart on an empty cache: three runs of
four left a cache that crashes).  Under the lock the first process compiles and writes, the others
wait and load what it wrote; after its first use a function takes no lock in that process.

The lock is ``fcntl.flock`` on a file in the temporary folder (no lock where ``fcntl`` is missing).
"""

from __future__ import annotations

import contextlib
import tempfile
from pathlib import Path

#: the lock file every process on the machine opens
LOCK_PATH = Path(tempfile.gettempdir()) / "headmotion-numba-cache.lock"
#: what this process has already used once (no lock needed again)
_USED: set[str] = set()


@contextlib.contextmanager
def _machine_lock():
    try:
        import fcntl
    except ImportError:  # no flock (Windows): no lock
        yield
        return
    fh = None
    for mode in ("a", "r"):  # another user's lock file can still be locked read-only
        try:
            fh = open(LOCK_PATH, mode)
            break
        except OSError:
            continue
    if fh is None:
        yield
        return
    with fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


@contextlib.contextmanager
def first_use(name: str):
    """The block under the machine-wide lock the first time this process runs ``name``."""
    if name in _USED:
        yield
        return
    with _machine_lock():
        yield
    _USED.add(name)


def import_librosa():
    """The ``librosa`` module, with the modules holding its ``guvectorize`` functions (compiled, or
    loaded from numba's cache, when they are imported) imported under the lock."""
    with first_use("import librosa"):
        import librosa
        import librosa.core.audio  # noqa: F401  zero crossings
        import librosa.core.pitch  # noqa: F401  parabolic interpolation
        import librosa.onset  # noqa: F401
        import librosa.util.utils  # noqa: F401  peak picking, local extrema
    return librosa


__all__ = ["first_use", "import_librosa", "LOCK_PATH"]
