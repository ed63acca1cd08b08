"""Settle the head in pauses: slow synthesised motion down where nobody speaks (a stage of
the post-processing chain, :mod:`headmotion.motion.post`).

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

Causal mode (streaming systems: the streamed output must equal the offline output):
:class:`CausalPauseWeight` decides from the speech flags up to the current frame only — the weight
stays 0 for the first ``delay_s`` (0.05 s) of a non-speech run, then rises with a raised cosine
to 1 at ``full_s`` (0.3 s) of silence (real heads slow at once when speech stops: ZEGGS 0.35 of
speech speed in the first 0.25 s; on the ZEGGS folds 0.15 s / 0.5 s left the pause ratio 0.47–0.60
against 0.37, 0.05 s / 0.3 s gives 0.41–0.49 with idle 0.4); speech that lasts ``min_speech_s``
(0.05 s) brings it back to 0 linearly within ``release_s`` (0.1 s).  :class:`PauseSettler` is the
velocity scaling of :func:`settle_in_pauses` as a recursion with state, so a stream that feeds it
chunk by chunk gets exactly what one call over the whole utterance gives.
:func:`settle_in_pauses` uses it too (``causal=True`` swaps the look-ahead weight for the causal one).

Library considered: scipy.signal filters act on whole signals with fixed coefficients; the
mask-dependent velocity scaling with offset relaxation is a few lines of numpy.
"""

from __future__ import annotations

import numpy as np

from ..features.vad import runs  # the one run finder
from ..errors import ParameterError
from ..types import Motion

#: measured on the ZEGGS mocap take (speed in pauses / speed in speech)
DEFAULT_IDLE = 0.4


def pause_mask(speech_mask, *, fps: float, min_pause_s: float = 0.5) -> np.ndarray:
    """True in the non-speech runs at least ``min_pause_s`` long (the pauses the realism measure counts)."""
    s = np.asarray(speech_mask, bool)
    out = np.zeros(len(s), bool)
    n = int(round(min_pause_s * float(fps)))
    for a, b in runs(~s):
        if b - a >= n:
            out[a:b] = True
    return out


def pause_speech_speeds(x, speech_mask, *, fps: float, min_pause_s: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Frame-to-frame speeds ``‖x_t − x_{t−1}‖`` (units of ``x`` per frame) inside pauses and inside
    speech, a speed belonging to a stretch when both its frames do: the two sides of the
    pause/speech speed ratio, returned apart so that they can be pooled over recordings."""
    n = min(len(x), len(speech_mask))   # a frame more or less at either end: the shorter
    x = np.asarray(x, dtype=np.float64)[:n]
    mask = np.asarray(speech_mask, bool)[:n]
    if n < 2:
        return np.zeros(0), np.zeros(0)
    sp = np.linalg.norm(np.diff(x, axis=0), axis=1)
    pauses = pause_mask(mask, fps=fps, min_pause_s=min_pause_s)
    return sp[pauses[1:] & pauses[:-1]], sp[mask[1:] & mask[:-1]]


def pooled_pause_ratio(pairs) -> float:
    """Mean speed in pauses over mean speed in speech, pooled over ``(pause_speeds, speech_speeds)``
    pairs of :func:`pause_speech_speeds` (nan when either side is empty)."""
    pairs = list(pairs)
    p = np.concatenate([a for a, _ in pairs]) if pairs else np.zeros(0)
    s = np.concatenate([b for _, b in pairs]) if pairs else np.zeros(0)
    if not len(p) or not len(s) or s.mean() <= 0:
        return float("nan")
    return float(p.mean() / s.mean())


def pause_weight(speech_mask, *, fps: float, min_pause_s: float = 0.5, ramp_s: float = 0.2) -> np.ndarray:
    """Per frame, how far into a pause (0 = speech or short gap, 1 = inside a pause).

    Non-speech runs of at least ``min_pause_s`` get 1, with raised-cosine ramps of ``ramp_s``
    seconds at both ends inside the run (at most half the run each).  This looks ahead (a run's
    length is known at its start); :class:`CausalPauseWeight` is the causal counterpart."""
    if fps <= 0:
        raise ParameterError(f"fps must be positive; got {fps}")
    if min_pause_s < 0 or ramp_s < 0:
        raise ParameterError(f"min_pause_s and ramp_s must be >= 0; got {min_pause_s}, {ramp_s}")
    s = np.asarray(speech_mask, dtype=bool)
    if s.ndim != 1:
        raise ParameterError(f"speech_mask must be 1-D (one flag per frame); given shape {s.shape}")
    w = np.zeros(len(s))
    shortest = max(1, int(round(min_pause_s * fps)))
    for a, b in runs(~s):
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


class CausalPauseWeight:
    """Causal pause weight (0 speech … 1 settled pause) from per-frame speech flags, fed in chunks.

    Parameters
    ----------
    fps : float
    delay_s : seconds of non-speech before the weight starts to rise (gaps between words stay 0)
    full_s : seconds of non-speech at which the weight reaches 1 (raised cosine from ``delay_s``)
    min_speech_s : speech must last this long to end a pause (single loud frames do not)
    release_s : time to go from 1 back to 0 once speech is confirmed (linear)
    """

    def __init__(self, *, fps: float, delay_s: float = 0.05, full_s: float = 0.3, min_speech_s: float = 0.05,
                 release_s: float = 0.1):
        if fps <= 0:
            raise ParameterError(f"fps must be positive; got {fps}")
        if not 0 <= delay_s < full_s or min_speech_s < 0 or release_s < 0:
            raise ParameterError(f"need 0 <= delay_s < full_s, min_speech_s >= 0 and release_s >= 0; got "
                                 f"{delay_s}, {full_s}, {min_speech_s}, {release_s}")
        self.fps = float(fps)
        self.delay = delay_s * self.fps
        self.full = full_s * self.fps
        self.min_speech = max(1, int(round(min_speech_s * self.fps)))
        self.step_down = 1.0 / max(release_s * self.fps, 1.0)
        self.t = 0              # frames seen
        self.last_speech = -1   # last frame with confirmed speech (-1: none yet)
        self.run = 0            # consecutive speech frames at the end of the last chunk
        self.peak = -np.inf     # running max of target[k] + step_down * k

    def push(self, flags) -> np.ndarray:
        """Weights of the next frames given their speech flags (True = speech).

        ``w[t] = max(target[t], w[t-1] - step)`` with ``target`` the raised-cosine ramp of the
        frames since the last confirmed speech, computed in closed form as
        ``max_{k<=t}(target[k] + step k) - step t`` (vectorised, and identical whether the
        utterance comes in one chunk or many)."""
        f = np.asarray(flags, dtype=bool).ravel()
        n = len(f)
        if n == 0:
            return np.zeros(0)
        idx = np.arange(self.t, self.t + n)
        # speech-run length at every frame (continuing the previous chunk's run)
        breaks = np.where(~f, idx, self.t - 1 - self.run)
        last_break = np.maximum.accumulate(breaks)
        run = np.where(f, idx - last_break, 0)
        confirmed = np.where(run >= self.min_speech, idx, self.last_speech)
        last = np.maximum.accumulate(confirmed)
        silence = idx - last
        u = np.clip((silence - self.delay) / (self.full - self.delay), 0.0, 1.0)
        target = 0.5 * (1.0 - np.cos(np.pi * u))
        m = np.maximum.accumulate(np.maximum(target + self.step_down * idx, self.peak))
        w = np.maximum(m - self.step_down * idx, target)
        self.peak = float(m[-1])
        self.last_speech = int(last[-1])
        self.run = int(run[-1])
        self.t += n
        return w

    def push_one(self, flag: bool) -> float:
        """The weight of the next frame: :meth:`push` of one flag with the same operations on
        scalars (numpy's cos, whose last bits can differ from ``math.cos``), for streams that emit
        a frame per 10 ms chunk."""
        t = self.t
        run = self.run + 1 if flag else 0
        last = t if run >= self.min_speech else self.last_speech
        u = min(max((t - last - self.delay) / (self.full - self.delay), 0.0), 1.0)
        target = 0.5 * (1.0 - float(np.cos(np.pi * u)))
        ramp = target + self.step_down * t
        m = ramp if ramp > self.peak else self.peak
        w = m - self.step_down * t
        self.peak, self.last_speech, self.run, self.t = float(m), int(last), run, t + 1
        return w if w >= target else target


class PauseSettler:
    """The velocity scaling of :func:`settle_in_pauses` as a recursion with state.

    ``push(x, w)`` takes the next frames ``x`` (n, D) of the system's motion and their pause
    weights ``w`` (n,) and returns the settled frames; feeding an utterance in chunks gives exactly
    the output of one call over the whole of it."""

    def __init__(self, *, fps: float, idle: float = DEFAULT_IDLE, relax_s: float = 1.0, pull: float = 0.0,
                 mean_pose=None):
        if not 0.0 <= idle <= 1.0:
            raise ParameterError(f"idle must be in [0, 1]; got {idle}")
        if relax_s <= 0 or pull < 0:
            raise ParameterError(f"relax_s must be > 0 and pull >= 0; got {relax_s}, {pull}")
        if pull > 0 and mean_pose is None:
            raise ParameterError("pull > 0 needs mean_pose")
        self.fps, self.idle, self.relax_s, self.pull = float(fps), float(idle), float(relax_s), float(pull)
        self.mu = None if mean_pose is None else np.asarray(mean_pose, dtype=np.float64)
        self.prev_x = None
        self.prev_y = None
        self.off = None

    def push_one(self, x, w: float) -> list[float]:
        """The next frame ``x`` (a sequence of D floats) with its pause weight ``w``, settled:
        :meth:`push` of one frame with the same operations on scalars (numpy's exp), for streams
        that emit a frame per 10 ms chunk.  Returns the settled frame as a list of floats."""
        if self.pull != 0.0 or self.prev_x is None:
            return self.push(np.asarray(x, dtype=np.float64)[None], np.array([w]))[0].tolist()
        x = [float(v) for v in x]
        rate1 = (1.0 - (1.0 - self.idle) * w) - 1.0
        decay = float(np.exp(-(1.0 - w) / (self.relax_s * self.fps)))
        off = [decay * (o + (rate1 * (xi - pi)) / decay) for o, xi, pi in zip(self.off, x, self.prev_x)]
        y = [xi + o for xi, o in zip(x, off)]
        self.off, self.prev_x, self.prev_y = off, x, y
        return y

    def push(self, x, w) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        w = np.asarray(w, dtype=np.float64)
        if len(w) != len(x):
            raise ParameterError(f"{len(x)} frames of motion but {len(w)} pause weights")
        y = np.empty_like(x)
        if len(x) == 0:
            return y
        rate = 1.0 - (1.0 - self.idle) * w
        decay = np.exp(-(1.0 - w) / (self.relax_s * self.fps))  # the offset decays only outside pauses
        k_pull = 1.0 - np.exp(-self.pull * w / self.fps)
        if self.prev_x is None:
            self.off = np.zeros(x.shape[1])
            self.prev_x, self.prev_y = x[0], x[0]
            first = x[:1]
            k_pull[0] = 0.0  # the utterance's first frame is the motion's
        else:
            # (push_one keeps its state as lists of floats)
            self.off, self.prev_x, self.prev_y = (np.asarray(self.off, dtype=np.float64),
                                                  np.asarray(self.prev_x, dtype=np.float64),
                                                  np.asarray(self.prev_y, dtype=np.float64))
            first = self.prev_x[None]
        dx = np.diff(np.vstack([first, x]), axis=0)   # dx[0] = 0 for the utterance's first frame
        u = (rate - 1.0)[:, None] * dx
        off, py = self.off, self.prev_y
        if self.pull == 0.0:
            # off[t] = decay[t] off[t-1] + u[t], in closed form over blocks short enough that the
            # running product of decays stays far from underflow (>= e^-5)
            B = max(1, int(5.0 * self.relax_s * self.fps))
            offs = np.empty_like(x)
            for b0 in range(0, len(x), B):
                P = np.cumprod(decay[b0:b0 + B])
                offs[b0:b0 + B] = P[:, None] * (off + np.cumsum(u[b0:b0 + B] / P[:, None], axis=0))
                off = offs[min(b0 + B, len(x)) - 1]
            y = x + offs
            px, py = x[-1], y[-1]
        else:
            for t in range(len(x)):
                off = off * decay[t] + u[t]
                yt = x[t] + off
                if k_pull[t] > 0:
                    yt = yt - k_pull[t] * (py + rate[t] * dx[t] - self.mu)
                    off = yt - x[t]
                y[t] = yt
                py = yt
            px = x[-1]
        self.off, self.prev_x, self.prev_y = off, px, py
        return y


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
    mean_pose : (D,), default the motion's mean
    causal : decide from the flags up to each frame only (:class:`CausalPauseWeight` with its
        defaults; ``min_pause_s`` and ``ramp_s`` are then unused)

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
    w = (CausalPauseWeight(fps=f).push(mask) if causal
         else pause_weight(mask, fps=f, min_pause_s=min_pause_s, ramp_s=ramp_s))
    if len(x) < 2 or not w.any():
        return motion
    mu = x.mean(axis=0) if mean_pose is None else np.asarray(mean_pose, dtype=np.float64)
    y = PauseSettler(fps=f, idle=idle, relax_s=relax_s, pull=pull, mean_pose=mu).push(x, w)
    if not is_motion:
        return y
    meta = dict(motion.meta)
    meta["pauses"] = {"causal": causal, "idle": idle, "min_pause_s": min_pause_s, "ramp_s": ramp_s, "relax_s": relax_s, "pull": pull}
    return motion.replace(rotvec=y, meta=meta)


__all__ = ["CausalPauseWeight", "PauseSettler", "pause_weight", "settle_in_pauses", "pause_mask", "pause_speech_speeds",
           "pooled_pause_ratio", "runs", "DEFAULT_IDLE"]
