"""Speech features over a whole corpus and paper Table 1 (paper §4.3 Table 1; thesis §5.7.1),
run per recording with :mod:`.parallel`.

* :func:`extract_corpus_features` — every feature set of every recording, aligned with the
  recording's motion (or at a given frame rate).
* :func:`feature_table` — paper Table 1: local CCA between each feature set and the recorded
  motion, with its circular-shift chance level, per recording.  Features are extracted and scored
  on the worker; only the scores come back (a 100-dim waveform track of an hour of speech is
  ~140 MB, its scores a few numbers).

Library considered: the feature extractors of :mod:`headmotion.features`; the table is ours.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ...corpus import Corpus
from ...errors import ParameterError
from ...types import FeatureTrack
from .parallel import map_recordings, sub_seed


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
    from ... import features as F

    return F.extract(fs, audio, fps=fps, n_frames=n_frames)


def _frames_for(rec, fps: float | None) -> tuple[float, int]:
    if fps is None:
        return float(rec.motion.fps), len(rec.motion)
    from ...align import n_frames

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
    n_jobs, scheduler : see :func:`.parallel.run_map` (one task per recording)
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
def _recording_table(rec, feature_sets: tuple, window_s: float, n_shifts: int, seed: int):
    from ..measures import chance as C
    from ..measures import metrics as M

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
                                 seed=sub_seed(seed, rec.id, "features", name))
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


__all__ = ["extract_corpus_features", "CorpusFeatures", "feature_table", "feature_set_name", "extract_one"]
