"""Speech features of a whole corpus computed once, in parallel, and kept on disk.

For corpora of tens of hours (BEAT2 is about 60): each recording's features are computed by one
task (joblib processes locally, or a Dask cluster with ``scheduler``, through
:func:`headmotion.parallel.run_map`) and written atomically to
``CORPUS/.features/<set>-<config hash>/<recording>.npz``.  A file is valid while the recording's
speech file keeps its size and modification time (stored in the file), so an interrupted build
resumes where it stopped and an edited recording is recomputed.  Memory holds one recording per
worker, never the corpus.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .features import FeatureConfig
from .types import FeatureTrack

CACHE_DIR = ".features"


def config_key(config: FeatureConfig) -> str:
    """``<set>-<first 10 hex digits of the configuration's hash>``: one folder per configuration."""
    text = json.dumps(config.to_dict(), sort_keys=True)
    return f"{config.name}-{hashlib.sha256(text.encode()).hexdigest()[:10]}"


def _stamp(path: Path) -> str:
    st = path.stat()
    return f"{st.st_size}:{st.st_mtime_ns}"


@dataclass(frozen=True)
class CacheTask:
    """One recording's work: its manifest entry's speech path and where its features go."""

    corpus_root: str
    recording: str
    config: dict
    sample_rate: int
    entry: object = None  # the manifest row (CorpusEntry): the worker does not read the manifest


def cache_path(corpus_root, recording: str, config: FeatureConfig) -> Path:
    return Path(corpus_root) / CACHE_DIR / config_key(config) / f"{recording}.npz"


def _audio_path(corpus, recording: str) -> Path:
    e = corpus.entries[corpus.ids.index(recording)]
    return Path(corpus.root) / e.audio


def load_cached(corpus, recording: str, config: FeatureConfig) -> FeatureTrack | None:
    """The cached features of ``recording``, or ``None`` when missing or stale."""
    return _read_track(cache_path(corpus.root, recording, config), _audio_path(corpus, recording))


def _read_track(path: Path, audio_path: Path) -> FeatureTrack | None:
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            if str(z["stamp"]) != _stamp(audio_path):
                return None
            return FeatureTrack(z["values"], float(z["fps"]), tuple(str(n) for n in z["names"]))
    except (OSError, KeyError, ValueError):
        return None  # a damaged file is recomputed


def features_for(recording, config: FeatureConfig, n_frames: int | None = None) -> FeatureTrack:
    """``config.extract(recording.audio, n_frames=n_frames)``, read from the corpus's feature cache
    when it holds a valid track for this recording (the same values: the cache is that extraction
    at the speech's own frame count, so it is used only when ``n_frames`` is that count).

    Parameters
    ----------
    recording : Recording (one from a corpus on disk carries where its corpus is, in ``meta``)
    config : FeatureConfig
    n_frames : int, optional — the length of the result, as for :func:`headmotion.features.extract`

    Returns
    -------
    FeatureTrack
    """
    from .align import n_frames as count_frames

    source = (getattr(recording, "meta", None) or {}).get("source")
    audio = recording.audio
    natural = count_frames(len(audio), audio.sample_rate, float(config.fps))
    if source and (n_frames is None or int(n_frames) == natural):
        track = _read_track(cache_path(source["corpus"], recording.id, config), Path(source["audio"]))
        if track is not None and len(track.values) == natural:
            return track
    return config.extract(audio, n_frames=n_frames)


def _compute(task: CacheTask) -> str:
    from .corpus import Corpus
    from .io.atomic import atomic_path

    corpus = (Corpus(root=Path(task.corpus_root), entries=[task.entry], sample_rate=task.sample_rate)
              if task.entry is not None else Corpus.load(task.corpus_root, sample_rate=task.sample_rate))
    config = FeatureConfig.from_dict(task.config)
    rec = corpus[task.recording]
    track = config.extract(rec.audio)
    with atomic_path(cache_path(task.corpus_root, task.recording, config)) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, values=track.values, fps=np.float64(track.fps), names=np.array(track.names),
                     stamp=np.array(_stamp(_audio_path(corpus, task.recording))))
    return task.recording


def build_feature_cache(corpus, configs, *, n_jobs: int = 1, scheduler=None,
                        progress: Callable | None = None) -> dict[str, int]:
    """Compute every missing or stale ``(recording, configuration)`` of an on-disk corpus.

    Parameters
    ----------
    corpus : Corpus loaded from a folder
    configs : FeatureConfig or list of them
    n_jobs : joblib processes; ignored with ``scheduler``
    scheduler : Dask scheduler address or ``distributed.Client``
    progress : ``progress(done, total, description)``, optional

    Returns
    -------
    dict with ``computed`` and ``cached`` (already valid, skipped) counts.
    """
    from .errors import ParameterError
    from .parallel import run_map

    if corpus.root is None:
        raise ParameterError("the feature cache needs a corpus on disk (Corpus.load(folder))")
    configs = [configs] if isinstance(configs, FeatureConfig) else list(configs)
    todo, cached = [], 0
    for config in configs:
        for e in corpus.entries:
            if _read_track(cache_path(corpus.root, e.recording, config), Path(corpus.root) / e.audio) is None:
                todo.append(CacheTask(str(corpus.root), e.recording, config.to_dict(), corpus.sample_rate, e))
            else:
                cached += 1
    run_map(_compute, todo, n_jobs=n_jobs, scheduler=scheduler, progress=progress,
            describe=lambda t: f"{t.config['name']} {t.recording}")
    return {"computed": len(todo), "cached": cached}


__all__ = ["build_feature_cache", "features_for", "load_cached", "cache_path", "config_key", "CACHE_DIR"]
