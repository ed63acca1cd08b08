"""Recent feature extractions kept in the process: the same speech asked for again is not analysed again.

Training and evaluation ask for one recording's features many times: every system of a comparison,
every fold it trains in, and a fit's cross-fitted predictions over its own training recordings
(:mod:`headmotion.systems.tws`).  :meth:`FeatureConfig.extract
<headmotion.features.FeatureConfig.extract>` keeps the tracks of the built-in feature sets here,
keyed by the configuration, the length asked for and a digest of the samples themselves (so an
edited array is a new key), the least recently used dropped past :data:`MAX_BYTES`.  A track's
values are read-only (:class:`~headmotion.types.FeatureTrack`), so every caller is handed the one
kept track.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

import numpy as np

from ..types import Audio, FeatureTrack

#: the feature values kept at most (the least recently used go first)
MAX_BYTES = 64 * 2 ** 20

_tracks: OrderedDict = OrderedDict()
_held = 0
_lock = threading.Lock()


def key(config, audio: Audio, n_frames) -> tuple:
    """What makes an extraction's result: the configuration (a FeatureConfig is hashable and compares
    by its fields), the length asked for, the rate and the samples' digest (BLAKE2b over their
    bytes: 12 ms for 3 minutes of 16 kHz speech, where the extraction takes ~0.5 s)."""
    x = np.ascontiguousarray(audio.samples)
    digest = hashlib.blake2b(x.view(np.uint8), digest_size=16).digest()
    return (config, None if n_frames is None else int(n_frames), int(audio.sample_rate), str(x.dtype), x.shape,
            digest)


def get(k) -> FeatureTrack | None:
    """The track kept under ``k``, or None."""
    with _lock:
        track = _tracks.get(k)
        if track is not None:
            _tracks.move_to_end(k)
        return track


def put(k, track: FeatureTrack) -> FeatureTrack:
    """Keep ``track`` under ``k`` (dropping the least recently used past :data:`MAX_BYTES`); returns it."""
    global _held
    size = track.values.nbytes
    if size > MAX_BYTES:
        return track
    with _lock:
        if k not in _tracks:
            _tracks[k] = track
            _held += size
        while _held > MAX_BYTES and _tracks:
            _, old = _tracks.popitem(last=False)
            _held -= old.values.nbytes
    return track


def clear() -> None:
    """Forget every kept track."""
    global _held
    with _lock:
        _tracks.clear()
        _held = 0


__all__ = ["key", "get", "put", "clear", "MAX_BYTES"]
