"""Do a listening head's nods follow the other party's back-channel cues?  A ruler that can fail.

Both sides are read independently of the listening layer (:mod:`headmotion.listener`), so the
measure does not check the layer against its own record of what it did:

* **nods** are read from the **output motion**: peaks of the head's pitch (nose down, degrees),
  low-passed at 5 Hz, with a prominence of at least 2° and a width (at half the prominence) of
  0.15–1.0 s, during the other party's turns (:func:`motion_nods`);
* **cues** are read from the other party's audio by **Praat** (parselmouth's autocorrelation pitch at
  Praat's own defaults, 10 ms steps) and Ward & Tsukahara (2000)'s rule as they state it, per turn
  (:func:`praat_cues`): a region of pitch below the turn's 26th-percentile pitch lasting ≥ 110 ms,
  starting after ≥ 700 ms of speech, at most one cue per 800 ms.  A cue's time is its region's start.

A nod 0.3–1.5 s after a cue is a **hit** (the rule's back-channel is due 0.7 s after the region's
start; a nod peaks a little after it begins).  The null circularly shifts the nods within the other
party's turns joined end to end (:func:`follow_test`): ``p`` is the share of shifts whose share of
hits is at least the observed one (with the observed one counted, ``(k + 1) / (n + 1)``); pooled over
seeds, each shift moves every seed's nods by its own offset.

Ward, N. and Tsukahara, W. (2000), "Prosodic features which cue back-channel responses in English
and Japanese", *Journal of Pragmatics* 32(8), 1177–1207.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ...errors import ParameterError

#: the nods read from the motion
NOD_LOWPASS_HZ = 5.0
NOD_PROMINENCE_DEG = 2.0
NOD_WIDTH_S = (0.15, 1.0)
#: a nod this long after a cue's region start follows it
HIT_S = (0.3, 1.5)
#: Ward & Tsukahara's rule as the ruler reads it (seconds; the percentile of the turn's pitch)
CUE_PERCENTILE = 26.0
CUE_MIN_REGION_S = 0.110
CUE_MIN_SPEECH_S = 0.700
CUE_REFRACTORY_S = 0.800
#: a run of speech ends after this long without a voiced frame (P3's "speech")
CUE_PAUSE_S = 0.300
PRAAT_STEP_S = 0.01

Spans = Sequence[tuple[float, float]]


def _in_spans(t: np.ndarray, spans: Spans) -> np.ndarray:
    keep = np.zeros(len(t), bool)
    for a, b in spans:
        keep |= (t >= a) & (t < b)
    return keep


def motion_nods(motion, spans: Spans) -> np.ndarray:
    """Times (s) of the nods of ``motion`` (a :class:`~headmotion.types.Motion`) within ``spans``:
    peaks of its pitch (degrees), low-passed at :data:`NOD_LOWPASS_HZ`, of prominence ≥
    :data:`NOD_PROMINENCE_DEG` and width :data:`NOD_WIDTH_S`."""
    from scipy.signal import butter, find_peaks, sosfiltfilt

    pitch = motion.as_pitch_yaw_roll(degrees=True)[:, 0]
    fps = float(motion.fps)
    if len(pitch) < 16:
        return np.zeros(0)
    cut = min(NOD_LOWPASS_HZ, 0.45 * fps)
    smooth = sosfiltfilt(butter(4, cut, fs=fps, output="sos"), pitch)
    peaks, _ = find_peaks(smooth, prominence=NOD_PROMINENCE_DEG,
                          width=(NOD_WIDTH_S[0] * fps, NOD_WIDTH_S[1] * fps))
    t = peaks / fps
    return t[_in_spans(t, spans)]


def _turn_cues(f0: np.ndarray, t0: float, step: float) -> list[float]:
    voiced = f0 > 0
    if voiced.sum() < 2:
        return []
    thr = np.percentile(f0[voiced], CUE_PERCENTILE)
    pause = int(round(CUE_PAUSE_S / step))
    need = int(round(CUE_MIN_REGION_S / step))
    cues: list[float] = []
    run_start, last_voiced, region = None, -10 ** 9, None
    for i, (f, v) in enumerate(zip(f0, voiced)):
        if v:
            if run_start is None or i - last_voiced > pause:
                run_start = i
            last_voiced = i
        elif i - last_voiced > pause:
            run_start = None
        if not (v and f < thr):
            region = None
            continue
        if region is None:
            region = i
            counted = False
        if counted or i - region + 1 < need:
            continue
        counted = True
        if run_start is None or (region - run_start) * step < CUE_MIN_SPEECH_S - 1e-9:
            continue
        start = t0 + region * step
        if cues and start - cues[-1] < CUE_REFRACTORY_S - 1e-9:
            continue
        cues.append(start)
    return cues


def praat_cues(audio, spans: Spans) -> np.ndarray:
    """Times (s) of the back-channel cues of ``audio`` (the other party, a
    :class:`~headmotion.types.Audio`) in each turn of ``spans``, by Praat's pitch and Ward &
    Tsukahara's rule with the percentile of the turn's own voiced pitch."""
    import parselmouth

    x = np.asarray(audio.samples, dtype=np.float64)
    sr = int(audio.sample_rate)
    out: list[float] = []
    for a, b in spans:
        i0, i1 = max(0, int(round(a * sr))), min(len(x), int(round(b * sr)))
        if i1 - i0 < sr // 10:
            continue
        pitch = parselmouth.Sound(x[i0:i1], sampling_frequency=sr).to_pitch(time_step=PRAAT_STEP_S)
        f0 = np.nan_to_num(pitch.selected_array["frequency"])
        first = pitch.xs()[0] if len(f0) else 0.0  # (a frame's time is its centre's)
        out += _turn_cues(f0, i0 / sr + first, PRAAT_STEP_S)
    return np.asarray(out)


def _hits(nods: np.ndarray, cues: np.ndarray) -> np.ndarray:
    """Per nod (any leading shape): whether it comes :data:`HIT_S` after one of ``cues``."""
    if not len(cues):
        return np.zeros(np.shape(nods), bool)
    d = np.asarray(nods, float)[..., None] - cues
    return np.any((d >= HIT_S[0]) & (d <= HIT_S[1]), axis=-1)


def hit_share(nods: np.ndarray, cues: np.ndarray) -> float:
    """The share of ``nods`` that come :data:`HIT_S` after a cue (nan without nods)."""
    nods = np.asarray(nods, float)
    return float(np.mean(_hits(nods, np.asarray(cues, float)))) if len(nods) else float("nan")


class _Joined:
    """The turns joined end to end: times in the turns to and from one circular axis."""

    def __init__(self, spans: Spans):
        self.starts = np.array([a for a, _ in spans], float)
        self.lens = np.array([b - a for a, b in spans], float)
        if not len(spans) or np.any(self.lens <= 0):
            raise ParameterError(f"the other party's turns must be spans (start, end) with end > start; got {spans!r:.80}")
        self.offs = np.concatenate([[0.0], np.cumsum(self.lens)])
        self.total = float(self.offs[-1])

    def to_axis(self, t: np.ndarray) -> np.ndarray:
        k = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.starts) - 1)
        return self.offs[k] + np.clip(t - self.starts[k], 0.0, self.lens[k])

    def from_axis(self, u: np.ndarray) -> np.ndarray:
        k = np.clip(np.searchsorted(self.offs, u, side="right") - 1, 0, len(self.starts) - 1)
        return self.starts[k] + (u - self.offs[k])


@dataclass(frozen=True)
class Trial:
    """One conversation: each seed's nods (seconds), the cues, the other party's turns."""

    nods: Sequence[np.ndarray]
    cues: np.ndarray
    spans: Spans


@dataclass
class FollowResult:
    """Hits against circularly shifted nods, per seed (pooled over the trials) and over all seeds."""

    nods: list[int]                 # nods per seed
    share: list[float]              # share of hits per seed
    shifted: list[float]            # mean share of the shifted nods per seed
    p: list[float]                  # per seed
    pooled_share: float
    pooled_shifted: float
    pooled_p: float
    n_cues: int
    shifts: int = field(default=1000)


def _p(null: np.ndarray, obs: float) -> float:
    return float((np.sum(null >= obs - 1e-9) + 1) / (len(null) + 1))


def follow_test(trials: Sequence[Trial], *, shifts: int = 1000, seed: int = 0) -> FollowResult:
    """Hits of the nods on the cues against ``shifts`` circular shifts of each trial's nods within
    its turns (each trial and seed shifted by its own offset), per seed and pooled."""
    trials = list(trials)
    if not trials or len({len(t.nods) for t in trials}) != 1:
        raise ParameterError("follow_test needs trials with the same number of seeds each")
    n_seeds = len(trials[0].nods)
    rng = np.random.default_rng(seed)
    obs = np.zeros(n_seeds)          # hits per seed
    count = np.zeros(n_seeds, int)   # nods per seed
    null = np.zeros((shifts, n_seeds))
    for t in trials:
        axis, cues = _Joined(t.spans), np.asarray(t.cues, float)
        for s, nods in enumerate(t.nods):
            nods = np.asarray(nods, float)
            offsets = rng.uniform(0.0, axis.total, size=(shifts, 1))
            if not len(nods):
                continue
            obs[s] += _hits(nods, cues).sum()
            count[s] += len(nods)
            moved = axis.from_axis((axis.to_axis(nods)[None, :] + offsets) % axis.total)
            null[:, s] += _hits(moved, cues).sum(axis=1)
    share = [float(obs[s] / count[s]) if count[s] else float("nan") for s in range(n_seeds)]
    shifted = [float(null[:, s].mean() / count[s]) if count[s] else float("nan") for s in range(n_seeds)]
    p = [_p(null[:, s], obs[s]) if count[s] else float("nan") for s in range(n_seeds)]
    total = int(count.sum())
    return FollowResult(nods=count.tolist(), share=share, shifted=shifted, p=p,
                        pooled_share=float(obs.sum() / total) if total else float("nan"),
                        pooled_shifted=float(null.sum(axis=1).mean() / total) if total else float("nan"),
                        pooled_p=_p(null.sum(axis=1), obs.sum()) if total else float("nan"),
                        n_cues=int(sum(len(t.cues) for t in trials)), shifts=shifts)


__all__ = ["motion_nods", "praat_cues", "hit_share", "follow_test", "Trial", "FollowResult", "HIT_S", "NOD_PROMINENCE_DEG",
           "NOD_WIDTH_S", "NOD_LOWPASS_HZ"]
