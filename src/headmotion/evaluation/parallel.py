"""Corpus-wide work spread over joblib or a Dask cluster (issue 6: folds *and* corpus-wide
feature extraction run on ``--scheduler ADDRESS``; paper Table 1, thesis §5.7.1).

* :func:`run_map` — ``[fn(item) for item in items]`` in order, serially, with joblib
  (``n_jobs``) or on a Dask cluster (``scheduler`` = address or ``distributed.Client``); used for
  the cross-validation folds and for everything done per recording.
* :func:`map_recordings` — :func:`run_map` over the recordings of a corpus.  A recording of an
  on-disk corpus that is not loaded yet travels as its manifest entry (a few hundred bytes) and is
  read by the worker, so a cluster with the corpus on shared storage never ships audio.
* :func:`extract_corpus_features` — every feature set of every recording, aligned with the
  recording's motion (or at a given frame rate).
* :func:`feature_table` — paper Table 1: local CCA between each feature set and the recorded
  motion, with its circular-shift chance level, per recording.  Features are extracted and scored
  on the worker; only the scores come back (a 100-dim waveform track of an hour of speech is
  ~140 MB, its scores a few numbers).

Determinism: every result depends only on the recording and the seed, never on which worker ran
it, so serial, joblib and Dask runs are identical (tested with a ``LocalCluster``).

Libraries considered: joblib (local processes) and dask.distributed (clusters) do the scheduling;
``dask.bag`` would add nothing over ``Client.map`` for one task per recording.
"""

from __future__ import annotations

import contextlib
import zlib
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ..corpus import Corpus
from ..errors import MissingDependencyError, ParameterError
from ..types import FeatureTrack


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


# -- features --------------------------------------------------------------------------------------
def feature_set_name(fs) -> str:
    """The name a feature set has in tables: the registry name, or a callable's ``__name__``."""
    return fs if isinstance(fs, str) else getattr(fs, "__name__", "callable")


def extract_one(fs, audio, *, fps: float, n_frames: int | None) -> FeatureTrack:
    """One feature set (registry name or ``callable(audio, fps=, n_frames=)``) of ``audio``."""
    if callable(fs):
        out = fs(audio, fps=fps, n_frames=n_frames)
        if not isinstance(out, FeatureTrack):
            a = np.asarray(out, dtype=np.float32)
            out = FeatureTrack(a if a.ndim == 2 else a[:, None], fps, tuple(f"f{i}" for i in range(a.shape[-1])))
        return out
    from .. import features as F

    return F.extract(fs, audio, fps=fps, n_frames=n_frames)


def _frames_for(rec, fps: float | None) -> tuple[float, int]:
    if fps is None:
        return float(rec.motion.fps), len(rec.motion)
    from ..align import n_frames

    return float(fps), n_frames(len(rec.audio.samples), rec.audio.sample_rate, float(fps))


def _recording_features(rec, feature_sets: tuple, fps: float | None, skip_errors: bool):
    f, T = _frames_for(rec, fps)
    tracks, errors = {}, {}
    for fs in feature_sets:
        name = feature_set_name(fs)
        try:
            tracks[name] = extract_one(fs, rec.audio, fps=f, n_frames=T)
        except Exception as exc:
            if not skip_errors:
                raise
            errors[name] = f"{type(exc).__name__}: {exc}"
    return tracks, errors


@dataclass
class CorpusFeatures:
    """Feature tracks of a corpus: ``tracks[recording][feature set] -> FeatureTrack``.

    ``errors[(recording, feature set)]`` holds the message of each extraction that failed (only
    with ``on_error="skip"``)."""

    tracks: dict[str, dict[str, FeatureTrack]]
    errors: dict[tuple[str, str], str] = field(default_factory=dict)

    def __getitem__(self, recording: str) -> dict[str, FeatureTrack]:
        return self.tracks[recording]

    def __len__(self) -> int:
        return len(self.tracks)


def extract_corpus_features(corpus: Corpus, feature_sets: Sequence, *, fps: float | None = None, n_jobs: int = 1,
                            scheduler=None, on_error: str = "raise", progress: Callable | None = None) -> CorpusFeatures:
    """Every feature set of every recording of ``corpus``, locally (joblib) or on Dask.

    Parameters
    ----------
    corpus : Corpus
    feature_sets : registry names (``"f0e"``, ``"mfcc"``, …) or ``callable(audio, fps=, n_frames=)``
    fps : frame rate of the features; ``None`` (default) = each recording's motion rate with
        exactly as many frames as its motion (aligned for CCA); a number = that rate, frames from
        the audio length.
    n_jobs, scheduler : see :func:`run_map` (one task per recording)
    on_error : ``"raise"`` or ``"skip"`` (a failing feature set is left out and its message kept
        in :attr:`CorpusFeatures.errors`)

    Returns
    -------
    CorpusFeatures — ``result[recording_id][feature_set]`` is a FeatureTrack ``(T, D)``
    """
    if on_error not in ("raise", "skip"):
        raise ParameterError(f"on_error must be 'raise' or 'skip'; got {on_error!r}")
    if fps is not None and not float(fps) > 0:
        raise ParameterError(f"fps must be positive; got {fps!r}")
    fsets = tuple(feature_sets)
    res = map_recordings(_recording_features, corpus, args=(fsets, fps, on_error == "skip"), n_jobs=n_jobs,
                         scheduler=scheduler, progress=progress)
    out = CorpusFeatures(tracks={})
    for rid, (tracks, errors) in zip(corpus.ids, res):
        out.tracks[rid] = tracks
        out.errors.update({(rid, k): v for k, v in errors.items()})
    return out


# -- paper Table 1 ----------------------------------------------------------------------------------
def _sub_seed(*parts) -> int:
    """A 32-bit seed from the global seed and names (stable across processes, unlike hash())."""
    ints = [p if isinstance(p, int) else zlib.crc32(str(p).encode()) for p in parts]
    return int(np.random.SeedSequence(ints).generate_state(1)[0])


def _recording_table(rec, feature_sets: tuple, window_s: float, n_shifts: int, seed: int):
    from . import chance as C
    from . import metrics as M

    vals: dict[str, float] = {}
    warns: list[str] = []
    short: list[tuple[str, int, int]] = []  # (feature set, window frames, CCA dimensions)
    fps, T = float(rec.motion.fps), len(rec.motion)
    win = max(3, min(int(round(window_s * fps)), T))
    tracks, errors = _recording_features(rec, feature_sets, None, True)
    for name, msg in errors.items():
        warns.append(f"feature set {name!r} on {rec.id}: {msg}")
    for name, ft in tracks.items():
        try:
            dims = 3 + M.as_array(ft)[0].shape[1]
            if win < dims + 10:
                short.append((name, win, dims))
                continue
            r = C.local_cca_null(rec.motion, ft, window=win, n_shifts=n_shifts,
                                 seed=_sub_seed(seed, rec.id, "features", name))
            vals[f"featcca_local[{name}]"] = r.score
            vals[f"featcca_local[{name}]_null_mean"] = r.null_mean
            vals[f"featcca_local[{name}]_excess"] = r.excess
            vals[f"featcca_local[{name}]_p"] = r.p_value
        except Exception as exc:  # a feature set that fails must not sink the evaluation
            warns.append(f"feature set {name!r} on {rec.id}: {type(exc).__name__}: {exc}")
    return vals, warns, short


def feature_table(corpus: Corpus, feature_sets: Sequence, *, window_s: float = 3.0, n_shifts: int = 200,
                  seed: int = 0, n_jobs: int = 1, scheduler=None,
                  progress: Callable | None = None) -> tuple[dict[str, dict[str, float]], list[str]]:
    """Paper Table 1 per recording: local CCA between each feature set and the recorded motion.

    For every recording and feature set ``fs``: ``featcca_local[fs]`` (local CCA over
    ``window_s``-second windows, thesis §4.3.1 / paper §4.3) and its circular-shift chance level
    ``featcca_local[fs]_null_mean``, ``_excess``, ``_p`` (:func:`.chance.local_cca_null`, seeded
    from ``(seed, recording, "features", fs)``).  A feature set whose dimension is too large for
    the window, or whose extraction fails, is left out with a warning.

    Returns ``({recording_id: {metric: value}}, warnings)``.
    """
    fsets = tuple(feature_sets)
    res = map_recordings(_recording_table, corpus, args=(fsets, float(window_s), int(n_shifts), int(seed)),
                         n_jobs=n_jobs, scheduler=scheduler, progress=progress)
    table, warns = {}, []
    short: dict[str, list[tuple[str, int, int]]] = {}
    for rid, (vals, w, sh) in zip(corpus.ids, res):
        table[rid] = vals
        warns += w
        for name, win, dims in sh:
            short.setdefault(name, []).append((rid, win, dims))
    for name, items in short.items():  # one warning per feature set, not one per recording
        wins = sorted({w for _, w, _ in items})
        span = f"{wins[0]}" if len(wins) == 1 else f"{wins[0]}–{wins[-1]}"
        which = items[0][0] if len(items) == 1 else f"{len(items)} of {len(table)} recordings"
        warns.append(f"feature set {name!r} left out on {which}: a {span}-frame window is too short for CCA of "
                     f"{items[0][2]} dimensions (needs > {items[0][2] + 9} frames; local CCA would be ~1 whatever the "
                     f"data) — use a longer --window")
    return table, warns


__all__ = ["run_map", "map_recordings", "extract_corpus_features", "CorpusFeatures", "feature_table",
           "feature_set_name", "extract_one", "dask_client"]
