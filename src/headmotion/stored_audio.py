"""Speech of on-disk recordings decoded when read, so that a large corpus fits in memory.

An hour of 16 kHz float32 speech is 230 MB: a 60-hour corpus (BEAT2) held as decoded audio is
14 GB.  :class:`StoredAudio` is an :class:`~headmotion.types.Audio` that knows its length and
rate but decodes its samples only when they are read, keeping the decoded speech of the most
recently read recordings in one process-wide cache bounded in bytes (:data:`CACHE_BYTES`, at least
the last one).  A list of every recording of a corpus then holds their motion (small at 100 fps)
and file references, not their speech; each read gives the very samples an eager load gives.
Pickled (to a joblib or Dask worker) it carries the file reference, not the samples.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Callable, Hashable

import numpy as np

from .types import Audio

CACHE_BYTES = 64 * 2**20  # 17 minutes of 16 kHz speech
_decoded: "OrderedDict[Hashable, np.ndarray]" = OrderedDict()
_lock = threading.Lock()


def _samples(key: Hashable, load: Callable[[], np.ndarray]) -> np.ndarray:
    with _lock:
        x = _decoded.get(key)
        if x is not None:
            _decoded.move_to_end(key)
            return x
    x = load()
    with _lock:
        _decoded[key] = x
        _decoded.move_to_end(key)
        total = sum(v.nbytes for v in _decoded.values())
        while len(_decoded) > 1 and total > CACHE_BYTES:
            _, old = _decoded.popitem(last=False)
            total -= old.nbytes
    return x


def clear_cache() -> None:
    """Forget every decoded recording (the next read decodes again)."""
    with _lock:
        _decoded.clear()


class StoredAudio(Audio):
    """Audio whose samples are decoded from disk when read (see the module docstring).

    Parameters
    ----------
    load : picklable callable returning the samples (float32, read-only), as an eager load gives
    n_samples, sample_rate : their count and rate (known without decoding)
    key : hashable naming the recording in the decoded cache
    """

    def __init__(self, load: Callable[[], np.ndarray], n_samples: int, sample_rate: int, key: Hashable):
        object.__setattr__(self, "_load", load)
        object.__setattr__(self, "_n_samples", int(n_samples))
        object.__setattr__(self, "sample_rate", int(sample_rate))
        object.__setattr__(self, "_key", key)

    @property
    def samples(self) -> np.ndarray:  # type: ignore[override]
        return _samples(self._key, self._load)

    @property
    def duration(self) -> float:
        return self._n_samples / self.sample_rate

    def __len__(self) -> int:
        return self._n_samples


__all__ = ["StoredAudio", "clear_cache", "CACHE_BYTES"]
