"""Settle the head in pauses: slow synthesised motion down where nobody speaks (issue 14 §3).

The seeds are silent on pauses: the thesis' systems are driven by speech features that carry no
information in silence, so they keep their speech rhythm through pauses.  Real heads do not.
Measured here (``scripts/realism_report.py`` and the diagnosis note, speech mask from
:func:`headmotion.features.vad.speaking_mask`, pauses = non-speech runs ≥ 0.5 s):

* the ZEGGS mocap take: mean speed in pauses / in speech = 0.39; by time since the pause's onset
  0.35 (first 0.25 s), 0.25 (0.25–0.5 s), 0.27 (0.5–1 s); back to 0.9 within 0.25 s after speech
  resumes.  The head slows at once (no slow decay) and does not return to a rest pose: its
  distance from the mean pose is 12.8° in pauses and 14.7° in speech;
* the talking-video corpus (video-derived pose, whose tracking jitter sets a floor): 0.59
  (IQR 0.47–0.93) per recording; 0.48 / 0.45 / 0.47 by time since onset; distance from the mean
  pose 3.6° in pauses, 4.7° in speech.

So the chosen behaviour is a *speed* change, not a return to neutral: in each pause the motion's
velocity is scaled by ``idle`` (default 0.4, the mocap's level) with raised-cosine ramps of
``ramp_s`` (0.2 s) inside the pause, so speed is back to normal when speech starts.  The motion
that was not done in the pause is kept as an offset that relaxes exponentially (``relax_s``,
default 1 s) once speech resumes, so the output rejoins the system's motion and never jumps.  An
optional ``pull`` (1/s, default 0: the recordings show little of it) draws the head towards the
mean pose in pauses.

Streaming: deciding that a non-speech run will last ``min_pause_s`` needs that much look-ahead;
the template-warping streams already have 0.7 s of latency, which covers 0.5 s.  Systems without
look-ahead (le2012's frame-by-frame ascent) use ``causal=True``: a run counts as a pause once it
has lasted ``min_pause_s`` (the slowing starts then, ramping up over ``ramp_s``), and the ramp back
to full speed runs over ``ramp_s`` *after* speech resumes; every output frame then depends only on
the mask and motion up to that frame.

Library considered: scipy.signal filters act on whole signals with fixed coefficients; the
mask-dependent velocity scaling with offset relaxation is a few lines of numpy.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..types import Motion

#: measured on the ZEGGS mocap take (speed in pauses / speed in speech)
DEFAULT_IDLE = 0.4


def _runs(mask: np.ndarray):
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def pause_weight(speech_mask, *, fps: float, min_pause_s: float = 0.5, ramp_s: float = 0.2,
                 causal: bool = False) -> np.ndarray:
    """Per frame, how far into a pause (0 = speech or short gap, 1 = inside a pause).

    Non-speech runs of at least ``min_pause_s`` get 1, with raised-cosine ramps of ``ramp_s``
    seconds at both ends inside the run (at most half the run each).  With ``causal``, frame t
    depends on the mask up to t only: the weight ramps up (raised cosine over ``ramp_s``) once a
    non-speech run has lasted ``min_pause_s`` and ramps down the same way once speech resumes."""
    if fps <= 0:
        raise ParameterError(f"fps must be positive; got {fps}")
    if min_pause_s < 0 or ramp_s < 0:
        raise ParameterError(f"min_pause_s and ramp_s must be >= 0; got {min_pause_s}, {ramp_s}")
    s = np.asarray(speech_mask, dtype=bool)
    if s.ndim != 1:
        raise ParameterError(f"speech_mask must be 1-D (one flag per frame); given shape {s.shape}")
    w = np.zeros(len(s))
    shortest = max(1, int(round(min_pause_s * fps)))
    if causal:
        k = int(round(ramp_s * fps))
        run, phase = 0, 0
        for t in range(len(s)):
            run = 0 if s[t] else run + 1
            phase = min(phase + 1, k) if run >= shortest else max(phase - 1, 0)
            w[t] = (1.0 if run >= shortest else 0.0) if k == 0 else 0.5 * (1 - np.cos(np.pi * phase / k))
        return w
    for a, b in _runs(~s):
        n = b - a
        if n < shortest:
            continue
        w[a:b] = 1.0
        k = min(int(round(ramp_s * fps)), n // 2)
        if k > 0:
            ramp = 0.5 * (1 - np.cos(np.pi * np.arange(1, k + 1) / (k + 1)))
            w[a:a + k] = ramp
            w[b - k:b] = ramp[::-1]
    return w


def settle_in_pauses(motion, speech_mask, *, fps: float | None = None, idle: float = DEFAULT_IDLE,
                     min_pause_s: float = 0.5, ramp_s: float = 0.2, relax_s: float = 1.0, pull: float = 0.0,
                     mean_pose=None, causal: bool = False):
    """Slow the motion down in pauses.

    Parameters
    ----------
    motion : Motion or array (T, D)
    speech_mask : bool array (T,), True where someone speaks, at the motion's rate
    fps : float, needed for a bare array
    idle : speed in pauses as a fraction of the motion's own (0 = hold still, 1 = unchanged)
    min_pause_s : shortest non-speech run treated as a pause (s)
    ramp_s : raised-cosine ramp at each end of a pause (s)
    relax_s : time constant (s) with which the offset left by a pause decays in speech
    pull : rate (1/s) of an exponential pull towards ``mean_pose`` in pauses (0 = none)
    mean_pose : (D,), default the motion's mean (give it with ``causal`` and ``pull``: the motion's
        mean is not known causally)
    causal : the causal pause weight of :func:`pause_weight` (output frame t depends on input and
        mask up to t only)

    Returns
    -------
    the same type as ``motion`` (a Motion keeps its fps, translation untouched, meta noted)
    """
    is_motion = isinstance(motion, Motion)
    x = np.asarray(motion.rotvec if is_motion else motion, dtype=np.float64)
    f = float(motion.fps) if is_motion and fps is None else fps
    if f is None:
        raise ParameterError("settle_in_pauses needs the frame rate: pass fps= or a Motion")
    if x.ndim != 2:
        raise ParameterError(f"motion must have shape (T, D); given {x.shape}")
    if not 0.0 <= idle <= 1.0:
        raise ParameterError(f"idle must be in [0, 1]; got {idle}")
    if relax_s <= 0 or pull < 0:
        raise ParameterError(f"relax_s must be > 0 and pull >= 0; got {relax_s}, {pull}")
    mask = np.asarray(speech_mask, dtype=bool)
    if len(mask) != len(x):
        raise ParameterError(f"speech mask has {len(mask)} frames but the motion {len(x)}; give it at the motion's rate")
    w = pause_weight(mask, fps=f, min_pause_s=min_pause_s, ramp_s=ramp_s, causal=causal)
    if len(x) < 2 or not w.any():
        return motion
    mu = x.mean(axis=0) if mean_pose is None else np.asarray(mean_pose, dtype=np.float64)
    rate = 1.0 - (1.0 - idle) * w
    decay = np.exp(-(1.0 - w) / (relax_s * f))  # offset decays only outside pauses
    k_pull = 1.0 - np.exp(-pull * w / f)
    dx = np.diff(x, axis=0)
    y = np.empty_like(x)
    y[0] = x[0]
    off = np.zeros(x.shape[1])
    for t in range(1, len(x)):
        off = off * decay[t] + (rate[t] - 1.0) * dx[t - 1]
        yt = x[t] + off
        if k_pull[t] > 0:
            yt = yt - k_pull[t] * (y[t - 1] + rate[t] * dx[t - 1] - mu)
            off = yt - x[t]
        y[t] = yt
    if not is_motion:
        return y
    meta = dict(motion.meta)
    meta["pauses"] = {"idle": idle, "min_pause_s": min_pause_s, "ramp_s": ramp_s, "relax_s": relax_s, "pull": pull,
                      "causal": causal}
    return motion.replace(rotvec=y, meta=meta)


__all__ = ["pause_weight", "settle_in_pauses", "DEFAULT_IDLE"]
