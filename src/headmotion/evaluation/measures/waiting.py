"""A head that waits: how a model moves through silence, beside how recorded heads move in their
pauses (docs/decisions/amount-and-adapt.md).

Recorded heads in pauses move about half as fast as in speech, drift slowly and shift posture now
and then; a synthesised head should neither freeze nor keep nodding.  The measures, on the same
footing as the detectability test's (:func:`~headmotion.evaluation.detection.detectability.prepare`: a
zero-phase 6 Hz low-pass at 25 fps, degrees):

* :func:`pause_segment_speeds` — the mean speed (°/s, the norm over pitch, yaw and roll) of every
  recorded pause (a speech-free run of at least ``min_pause_s``, :func:`headmotion.motion.pauses.pause_mask`),
  and the pooled pause/speech speed ratio of the recordings;
* :func:`waiting` — a model on ``seconds`` of digital silence: its speed, its speed over its own
  speed in speech (given speech files), and its limit-cycle index
  (:func:`~headmotion.evaluation.measures.realism.limit_cycle_index`: the highest peak of the velocity
  autocorrelation between 0.25 and 2 s — a head that repeats one movement every decision scores high).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...motion.pauses import pause_mask, pause_speech_speeds, pooled_pause_ratio, runs
from ...types import Audio
from ..detection.detectability import FPS, prepare
from .realism import limit_cycle_index, speech_mask_for


def _speed(x: np.ndarray) -> np.ndarray:
    """Frame-to-frame speed (°/s) of prepared degrees."""
    return np.linalg.norm(np.diff(x, axis=0), axis=1) * FPS


def _prepared(motion, audio) -> tuple[np.ndarray, np.ndarray]:
    """(prepared degrees, speech mask) of one motion and its speech, at 25 fps."""
    x = prepare(motion)
    mask = speech_mask_for(audio, motion.resample(FPS))[:len(x)]
    return x[:len(mask)], mask


@dataclass
class PauseSpeeds:
    """Recorded pauses: each segment's mean speed (°/s), and the pause/speech speed ratio pooled over
    the recordings."""

    segments: np.ndarray
    ratio: float

    def percentiles(self, q=(10, 50, 90)) -> np.ndarray:
        return np.percentile(self.segments, q) if len(self.segments) else np.full(len(q), np.nan)


def pause_segment_speeds(recordings: Sequence, *, min_pause_s: float = 0.5) -> PauseSpeeds:
    """The speeds of the recorded pauses of ``recordings`` (items with ``motion`` and ``audio``)."""
    seg, pairs = [], []
    for r in recordings:
        x, mask = _prepared(r.motion, r.audio)
        pairs.append(pause_speech_speeds(x, mask, fps=FPS, min_pause_s=min_pause_s))
        v = _speed(x)
        seg += [float(v[a:b - 1].mean()) for a, b in runs(pause_mask(mask, fps=FPS, min_pause_s=min_pause_s))
                if b - a > 2]
    ratio = pooled_pause_ratio(pairs)
    return PauseSpeeds(np.asarray(seg), ratio)


@dataclass
class Waiting:
    """A model through silence: mean speed (°/s) per seed, its ratio to the model's speed in speech
    (nan without speech), and the limit-cycle index per seed."""

    speed: np.ndarray
    ratio: float
    loop: np.ndarray


def waiting(model, *, seconds: float = 20.0, seeds: Sequence[int] = (0, 1, 2, 3), speech: Sequence[Audio] = (),
            min_pause_s: float = 0.5) -> Waiting:
    """``model`` (anything :func:`headmotion.synthesis.synthesize` takes) on ``seconds`` of silence
    with each seed; its speed in speech is measured on the speech frames of ``speech`` (seed 0)."""
    from ...synthesis import synthesize

    silence = Audio(np.zeros(int(seconds * 16000), np.float32), 16000)
    speeds, loops = [], []
    for s in seeds:
        x = prepare(synthesize(silence, model, seed=int(s))[0])
        speeds.append(float(_speed(x).mean()))
        # a held head has no loop (its velocity is rounding noise, whose autocorrelation means nothing)
        loops.append(limit_cycle_index(np.radians(x), fps=FPS)[0] if speeds[-1] > 1e-6 else 0.0)
    in_speech = []
    for audio in speech:
        x, mask = _prepared(synthesize(audio, model, seed=0)[0], audio)
        in_speech.append(pause_speech_speeds(x, mask, fps=FPS, min_pause_s=min_pause_s)[1] * FPS)
    v = np.concatenate(in_speech) if in_speech else np.zeros(0)
    ratio = float(np.mean(speeds) / v.mean()) if len(v) and v.mean() > 0 else float("nan")
    return Waiting(np.asarray(speeds), ratio, np.asarray(loops))


__all__ = ["PauseSpeeds", "Waiting", "pause_segment_speeds", "waiting"]
