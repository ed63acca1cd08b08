"""Frame counts and alignment of tracks with different rates and lengths (thesis §3.4).

The thesis trimmed the audio to exactly match the motion capture; real recordings differ by a few
frames (encoder padding, a dropped final frame).  :func:`align_tracks` trims every track to the
shortest common duration when the lengths agree within a tolerance (default: one frame of the
coarsest track plus 50 ms) and raises :class:`~headmotion.errors.LengthMismatchError`, naming both
lengths, beyond it.

The two tracks of one recording on disk (a corpus entry) may disagree by more: public corpora
ship speech a fraction of a second longer than the motion (BEAT2: 64.10 s of speech beside 63.53 s
of motion), and their own loaders cut both to the shorter.  :func:`recording_tolerance_s` states
the rule every corpus command uses, at import and at load alike: trimmed when the difference is at
most ``TRIM_MAX_S`` (1 s) **and** at most ``TRIM_MAX_SHARE`` (2 %) of the shorter track, refused
beyond.

Frame times, one convention for every resampler (:meth:`headmotion.types.Motion.resample`,
:func:`resample_track`): frame ``t`` of a track at ``fps`` stands for time ``t / fps`` (its start),
and frame ``t`` covers ``[t / fps, (t + 1) / fps)`` (:func:`n_frames`).  Lengths are made equal by
one helper, :func:`fit_length` (trim, or repeat the last frame).
"""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np

from .errors import LengthMismatchError, ParameterError
from .types import Audio, FeatureTrack, Motion

Track = TypeVar("Track", Audio, Motion, FeatureTrack)

DEFAULT_TOLERANCE_S = 0.05
#: A recording's speech and motion are cut to the shorter when they differ by at most this many
#: seconds and at most this share of the shorter track (:func:`recording_tolerance_s`).
TRIM_MAX_S = 1.0
TRIM_MAX_SHARE = 0.02


def recording_tolerance_s(durations) -> float:
    """Seconds by which the tracks of one recording may differ and still be trimmed to the shorter.

    The larger of :data:`DEFAULT_TOLERANCE_S` and ``min(TRIM_MAX_S, TRIM_MAX_SHARE * shortest)``:
    a 64 s take may lose up to 1 s, a 10 s clip up to 0.2 s, a 2 s clip only the default 50 ms
    (plus the one-frame allowance of :func:`align_tracks`)."""
    shortest = min(float(d) for d in durations)
    if not math.isfinite(shortest) or shortest < 0:
        raise ParameterError(f"track durations must be finite and non-negative; got {list(durations)}")
    return max(DEFAULT_TOLERANCE_S, min(TRIM_MAX_S, TRIM_MAX_SHARE * shortest))


def n_frames(n_samples: int, sample_rate: float, fps: float) -> int:
    """Number of whole frames at ``fps`` covering ``n_samples`` at ``sample_rate``.

    Frame ``t`` covers ``[t / fps, (t + 1) / fps)``; a trailing part frame counts when at least half
    of it is present (rounding), so 1 s at 16 kHz is exactly 100 frames at 100 fps and odd lengths
    round to the nearest frame."""
    if n_samples < 0 or sample_rate <= 0 or fps <= 0:
        raise ParameterError(
            f"n_frames needs n_samples >= 0 and positive rates; got {n_samples}, {sample_rate}, {fps}"
        )
    return int(math.floor(n_samples * fps / sample_rate + 0.5))


def _rate(track) -> float:
    if isinstance(track, Audio):
        return float(track.sample_rate)
    if isinstance(track, (Motion, FeatureTrack)):
        return float(track.fps)
    raise ParameterError(f"cannot align an object of type {type(track).__name__}")


def _length(track) -> int:
    return len(track)


def _trim(track, n: int):
    if isinstance(track, Audio):
        return track if len(track) == n else Audio(track.samples[:n], track.sample_rate)
    if len(track) == n:
        return track
    return track.slice_frames(0, n)


def align_tracks(*tracks: Track, tolerance_s: float = DEFAULT_TOLERANCE_S, tolerance_frames: float = 1.0,
                 names: tuple[str, ...] | None = None) -> tuple:
    """Trim tracks of any rates to a common duration.

    Parameters
    ----------
    *tracks : Audio | Motion | FeatureTrack
    tolerance_s : float
        Seconds of disagreement allowed on top of ``tolerance_frames`` frames of the coarsest track.
    tolerance_frames : float
    names : tuple of str, optional
        Labels (e.g. file names) used in the error message.

    Returns
    -------
    tuple of the same types, each cut to the shortest duration (in whole frames of its own rate).

    Raises
    ------
    LengthMismatchError
        When the longest and shortest durations differ by more than the tolerance.
    """
    if not tracks:
        return ()
    durations = [_length(t) / _rate(t) for t in tracks]
    coarsest = min(_rate(t) for t in tracks)
    tol = tolerance_frames / coarsest + tolerance_s
    shortest = min(durations)
    longest = max(durations)
    if longest - shortest > tol + 1e-9:
        labels = names or tuple(type(t).__name__ for t in tracks)
        parts = ", ".join(
            f"{lab}: {_length(t)} {'samples' if isinstance(t, Audio) else 'frames'} at {_rate(t):g}/s "
            f"= {d:.3f} s"
            for lab, t, d in zip(labels, tracks, durations)
        )
        raise LengthMismatchError(
            f"track lengths differ by {longest - shortest:.3f} s, more than the tolerance of "
            f"{tol:.3f} s ({parts})"
        )
    out = []
    for t in tracks:
        n = min(_length(t), int(math.floor(shortest * _rate(t) + 1e-6)))
        out.append(_trim(t, n))
    # whole-frame rounding can leave frame-rate tracks one frame apart; equalise same-rate tracks
    by_rate: dict[float, int] = {}
    for t in out:
        by_rate[_rate(t)] = min(by_rate.get(_rate(t), 1 << 62), _length(t))
    return tuple(_trim(t, by_rate[_rate(t)]) for t in out)


def fit_length(values, n: int) -> np.ndarray:
    """``values`` (T, ...) trimmed, or padded by repeating the last frame, to exactly ``n`` rows
    (zeros when ``values`` is empty)."""
    v = np.asarray(values)
    T = v.shape[0]
    if T == n:
        return v
    if T > n:
        return v[:n]
    if T == 0:
        return np.zeros((n,) + v.shape[1:], dtype=v.dtype)
    return np.concatenate([v, np.repeat(v[-1:], n - T, axis=0)], axis=0)


def resample_track(track: FeatureTrack, fps: float, n: int | None = None) -> FeatureTrack:
    """Linear interpolation of a feature track to ``fps`` (``n`` frames, default by duration);
    frame ``t`` at time ``t / fps`` (the module's convention), held past the last frame."""
    if n is None:
        n = max(1, int(round(track.duration * fps)))
    t_old = np.arange(len(track)) / track.fps
    t_new = np.arange(n) / fps
    vals = np.stack([np.interp(t_new, t_old, track.values[:, k]) for k in range(track.dim)], 1)
    return FeatureTrack(vals, fps, track.names)


__all__ = ["n_frames", "align_tracks", "resample_track", "fit_length", "DEFAULT_TOLERANCE_S", "TRIM_MAX_S",
           "TRIM_MAX_SHARE", "recording_tolerance_s"]
