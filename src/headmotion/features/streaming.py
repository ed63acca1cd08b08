"""Incremental F0 + energy features for low-latency streaming (issue 16; paper §4.1 "F0+Energy",
thesis §2.2.4 — the seeds describe the offline feature set only; the on-line variant is ours).

:class:`StreamingF0e` computes the same six columns as the offline ``f0e`` set — ``[logf0,
energy, Δlogf0, Δenergy, ΔΔlogf0, ΔΔenergy]`` (``+ voiced`` with ``voicing=True``) — frame by
frame as audio arrives: ``push(samples)`` returns the frames that became final, ``flush()`` the
rest at the end of the stream.  :func:`f0e_live` (registered as the feature set ``"f0e-live"``)
computes a whole file by pushing it through the very same object, so a streamed run and an offline
run of the same 16 kHz audio give **bit-identical** values whatever the chunking (every per-frame
computation sees the same inputs in the same order; nothing is accumulated across chunks).

What differs from the offline ``f0e`` (:mod:`headmotion.features.prosody`) and why:

* **F0 — per-frame YIN** (de Cheveigné & Kawahara 2002), written here in numpy: the difference
  function ``d(τ) = e₀ + e_τ − 2 r(τ)`` on a window of ``W + τmax`` samples centred on the frame
  (``W`` = 25 ms, ``τmax`` = one period of ``pitch_floor`` → 38.4 ms at 75 Hz), cumulative-mean
  normalised, first dip under ``threshold`` (else the global minimum), parabolic interpolation.
  The frame is voiced when the dip is under ``voicing_threshold`` and the frame energy is above
  ``silence_db``.  Praat (the offline tracker, through parselmouth) works on the whole signal
  (global silence threshold, Viterbi path) and cannot run on a stream; librosa's ``yin`` computes
  the same normalised difference but returns no aperiodicity (so no voicing decision) and costs
  ~10× more per single-window call; ``pyin`` needs the whole signal for its HMM.
* **Unvoiced frames hold the last voiced log F0** (the causal half of the offline rule "ends hold
  the nearest voiced value"; interpolating towards the *next* voiced frame would need unbounded
  lookahead).  Before the first voiced frame: ``sqrt(floor · ceiling)`` as offline.
* **Smoothing and deltas with short lookahead.**  The 10-frame moving average (paper §4.1) takes
  ``smooth_lookahead`` future frames (default 2; offline: 4) and ``smooth_frames − 1 −
  smooth_lookahead`` past ones.  Δ is the least-squares slope of the line through ``delta_width``
  (5, HTK's N = 2) frames ending ``delta_lookahead`` frames in the future (default 1; offline HTK:
  2) — the same regression weights as HTK, evaluated over a window shifted into the past — and ΔΔ
  is the same slope of Δ.  Indices before the first frame / after the last clip to the end frame.

Latency budget (defaults, 16 kHz, 100 fps; frame ``t``'s time is its start ``t / fps`` as in the
stream's JSON lines, its centre is ``(t + 0.5) / fps``):

===================================================  ==========
F0 window: half of 25 ms + 13.4 ms (τmax), centred    19.2 ms beyond the frame centre
half a frame (centre vs. start)                         5 ms
smoothing lookahead, 2 frames                          20 ms
Δ lookahead, 1 frame                                   10 ms
ΔΔ lookahead, 1 frame                                  10 ms
**features final** (``lookahead_s``)                 **64.2 ms**
===================================================  ==========

Add the push granularity (≤ 10 ms with 10 ms chunks) and the on-stream resampler's delay (0 at
16 kHz in; a few ms through soxr otherwise): ≈ 75–80 ms, leaving ≥ 20 ms of the issue's 100 ms for
the synthesiser (the template-warping generator itself is causal: it adds 0).  ``lookahead_s`` is
exact for any parameters: frame ``t`` is final once the sample ``(t+K+0.5)·sr/fps + W_f/2`` is in,
``K = smooth_lookahead + 2 · delta_lookahead``.

Cost: ~0.1 ms per 10 ms frame on one core (numpy; see ``benchmarks/run.py --only features``).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from ..types import Audio
from .prosody import PITCH_CEILING, PITCH_FLOOR

NAMES = ["logf0", "energy", "d_logf0", "d_energy", "dd_logf0", "dd_energy"]


def regression_weights(width: int, lookahead: int) -> np.ndarray:
    """Weights ``w`` of the least-squares slope over frames ``t − (width − 1 − lookahead) … t +
    lookahead``: ``Δ_t = Σ_k w_k x_{t+k}``.  With ``lookahead = width // 2`` this is HTK's delta
    ``Σ n (x_{t+n} − x_{t−n}) / (2 Σ n²)``."""
    k = np.arange(width, dtype=np.float64)
    k -= k.mean()
    return k / np.sum(k * k)


def yin_frame(x: np.ndarray, win: int, tau_min: int, tau_max: int, threshold: float):
    """YIN on one window ``x`` of ``win + tau_max`` samples.

    Returns ``(period in samples (float), aperiodicity d'(τ*))``; ``(0, 1)`` for a silent window.
    """
    x = np.asarray(x, dtype=np.float64)
    r = np.correlate(x, x[:win], mode="valid")[: tau_max + 1]          # r(τ) = Σ_j x_j x_{j+τ}
    c = np.concatenate(([0.0], np.cumsum(x * x)))
    e = c[win:win + tau_max + 1] - c[:tau_max + 1]                      # e_τ = Σ_j x²_{j+τ}
    d = e[0] + e - 2.0 * r
    d[0] = 0.0
    d = np.maximum(d, 0.0)
    cs = np.cumsum(d[1:])
    if cs[-1] <= 0.0:
        return 0.0, 1.0
    dn = np.ones(tau_max + 1)
    dn[1:] = d[1:] * np.arange(1, tau_max + 1) / np.maximum(cs, 1e-30)
    seg = dn[tau_min:tau_max + 1]
    below = np.flatnonzero(seg < threshold)
    if below.size:
        i = int(below[0])
        while i + 1 < seg.size and seg[i + 1] < seg[i]:   # walk down to the dip's bottom
            i += 1
    else:
        i = int(np.argmin(seg))
    tau = i + tau_min
    ap = float(dn[tau])
    if tau_min < tau < tau_max:                          # parabolic interpolation
        a, b, cc = dn[tau - 1], dn[tau], dn[tau + 1]
        den = a - 2.0 * b + cc
        shift = 0.5 * (a - cc) / den if den > 0 else 0.0
        return tau + float(np.clip(shift, -1.0, 1.0)), ap
    return float(tau), ap


class StreamingF0e:
    """Incremental F0 + energy features (see the module docstring).

    Parameters
    ----------
    sample_rate : int, rate of the pushed samples (16000 to match the ``f0e-live`` feature set)
    fps : float, frame rate
    smooth_frames : int, moving-average length (default ``round(0.1 · fps)``)
    smooth_lookahead : int, future frames in the moving average (at most ``smooth_frames − 1``)
    delta_width : int, odd, frames in the Δ / ΔΔ regression
    delta_lookahead : int, future frames in each of Δ and ΔΔ (≤ ``delta_width − 1``)
    pitch_floor, pitch_ceiling : float, Hz
    window_s : float, energy window and YIN integration window (s)
    threshold : float, YIN dip threshold
    voicing_threshold : float, largest aperiodicity of a voiced frame
    silence_db : float, frames with less energy (dB re full scale) are unvoiced
    max_jump_semitones : float
        A voiced frame whose F0 is further than this from the median of the (up to 5) voiced frames
        of the last ``jump_memory_s`` is taken as an octave error and treated as unvoiced (0: off)
    voicing : bool, append the raw 0/1 voicing flag as column ``voiced``
    """

    def __init__(self, *, sample_rate: int = 16000, fps: float = 100.0, smooth_frames: int | None = None,
                 smooth_lookahead: int = 2, delta_width: int = 5, delta_lookahead: int = 1,
                 pitch_floor: float = PITCH_FLOOR, pitch_ceiling: float = PITCH_CEILING,
                 window_s: float = 0.025, threshold: float = 0.1, voicing_threshold: float = 0.35,
                 silence_db: float = -55.0, max_jump_semitones: float = 5.0, jump_memory_s: float = 0.3,
                 voicing: bool = False):
        if not (isinstance(sample_rate, (int, np.integer)) and sample_rate >= 1000):
            raise ParameterError(f"sample_rate must be a whole number of Hz >= 1000; got {sample_rate!r}")
        fps = float(fps)
        if not (math.isfinite(fps) and 0 < fps <= sample_rate / 4):
            raise ParameterError(f"fps must be positive and at most sample_rate / 4; got {fps!r}")
        if smooth_frames is None:
            smooth_frames = max(1, int(round(0.1 * fps)))
        if int(smooth_frames) < 1 or int(smooth_lookahead) < 0:
            raise ParameterError(f"need smooth_frames >= 1 and smooth_lookahead >= 0; "
                                 f"got {smooth_frames}, {smooth_lookahead}")
        if delta_width < 3 or delta_width % 2 == 0 or not 0 <= delta_lookahead < delta_width:
            raise ParameterError(f"need an odd delta_width >= 3 and 0 <= delta_lookahead < delta_width; "
                                 f"got {delta_width}, {delta_lookahead}")
        if not 0 < pitch_floor < pitch_ceiling < sample_rate / 4:
            raise ParameterError(f"need 0 < pitch_floor < pitch_ceiling < sample_rate / 4; "
                                 f"got {pitch_floor}, {pitch_ceiling}")
        if window_s <= 0:
            raise ParameterError(f"window_s must be positive seconds; got {window_s}")
        self.sample_rate = int(sample_rate)
        self.fps = fps
        self.voicing = bool(voicing)
        self.names = NAMES + (["voiced"] if voicing else [])
        self.S = int(smooth_frames)
        self.Ls = min(int(smooth_lookahead), self.S - 1)
        self.Ld = int(delta_lookahead)
        self.Wd = int(delta_width)
        self.w_delta = regression_weights(self.Wd, self.Ld)
        self.win = max(1, int(round(window_s * sample_rate)))             # energy / YIN integration
        self.hamming = np.hamming(self.win)
        self.tau_min = max(2, int(math.floor(sample_rate / pitch_ceiling)))
        self.tau_max = int(math.ceil(sample_rate / pitch_floor))
        self.f0_len = self.win + self.tau_max                              # YIN window
        self.threshold = float(threshold)
        self.voicing_threshold = float(voicing_threshold)
        self.silence_db = float(silence_db)
        self.max_jump = float(max_jump_semitones) * math.log(2.0) / 12.0
        self.jump_memory = max(1, int(round(jump_memory_s * fps)))
        self.default_logf0 = 0.5 * (math.log(pitch_floor) + math.log(pitch_ceiling))
        self.K = self.Ls + 2 * self.Ld                                     # frames of lookahead
        # state
        self._buf = np.zeros(0, dtype=np.float64)
        self._buf0 = 0            # absolute index of _buf[0]
        self._n_in = 0            # samples pushed so far
        self._static: dict[int, np.ndarray] = {}
        self._smooth: dict[int, np.ndarray] = {}
        self._d1: dict[int, np.ndarray] = {}
        self._voiced: dict[int, float] = {}
        self._last_logf0 = self.default_logf0
        self._recent: list[tuple[int, float]] = []   # (frame, log F0) of the last voiced frames
        self._n_static = 0        # frames with static values
        self._n_smooth = 0
        self._n_d1 = 0
        self._n_out = 0
        self._total: int | None = None   # known at flush
        self._flushed = False

    # -- geometry --------------------------------------------------------------------------------
    def _centre(self, t: int) -> float:
        return (t + 0.5) * self.sample_rate / self.fps

    def _start(self, t: int, length: int) -> int:
        return int(math.floor(self._centre(t) - length / 2 + 0.5))

    def _needed(self, t: int) -> int:
        """Samples needed (exclusive end) before frame t's static values can be computed."""
        return max(self._start(t, self.f0_len) + self.f0_len, self._start(t, self.win) + self.win)

    @property
    def lookahead_s(self) -> float:
        """Audio needed beyond a frame's start time before that frame is final (seconds)."""
        t = 1000
        return (self._needed(t + self.K) - t * self.sample_rate / self.fps) / self.sample_rate

    @property
    def latency_ms(self) -> float:
        return 1000.0 * self.lookahead_s

    @property
    def frames_out(self) -> int:
        return self._n_out

    # -- stages ----------------------------------------------------------------------------------
    def _window(self, start: int, length: int) -> np.ndarray:
        """Samples [start, start + length), zeros outside what was pushed (and before 0)."""
        out = np.zeros(length, dtype=np.float64)
        lo, hi = max(start, self._buf0), min(start + length, self._n_in)
        if hi > lo:
            out[lo - start:hi - start] = self._buf[lo - self._buf0:hi - self._buf0]
        return out

    def _static_frame(self, t: int) -> None:
        xe = self._window(self._start(t, self.win), self.win)
        p = float(np.dot(xe * xe, self.hamming * self.hamming) / np.sum(self.hamming * self.hamming))
        energy = max(10.0 * math.log10(max(p, 1e-30)), -100.0)
        xf = self._window(self._start(t, self.f0_len), self.f0_len)
        period, ap = yin_frame(xf, self.win, self.tau_min, self.tau_max, self.threshold)
        voiced = period > 0 and ap < self.voicing_threshold and energy > self.silence_db
        if voiced:
            logf0 = math.log(self.sample_rate / period)
            recent = [v for k, v in self._recent if k >= t - self.jump_memory]
            if self.max_jump > 0 and recent and abs(logf0 - float(np.median(recent))) > self.max_jump:
                voiced = False          # an octave-like jump away from the recent voiced frames
            else:
                self._recent = [(k, v) for k, v in self._recent if k >= t - self.jump_memory][-4:] + [(t, logf0)]
                self._last_logf0 = logf0
        self._static[t] = np.array([self._last_logf0, energy])
        self._voiced[t] = 1.0 if voiced else 0.0

    def _clip(self, t: int) -> int:
        t = max(t, 0)
        return t if self._total is None else min(t, self._total - 1)

    def _smooth_frame(self, t: int) -> None:
        idx = [self._clip(k) for k in range(t - (self.S - 1 - self.Ls), t + self.Ls + 1)]
        self._smooth[t] = np.mean(np.stack([self._static[k] for k in idx]), axis=0)

    def _delta(self, src: dict, t: int) -> np.ndarray:
        idx = [self._clip(k) for k in range(t - (self.Wd - 1 - self.Ld), t + self.Ld + 1)]
        return self.w_delta @ np.stack([src[k] for k in idx])

    def _advance(self) -> np.ndarray:
        total = self._total
        # static values: all frames whose windows are in (or every frame, once the end is known)
        while (self._n_in >= self._needed(self._n_static)) if total is None else self._n_static < total:
            self._static_frame(self._n_static)
            self._n_static += 1
        ready = lambda n_src, t, la: (t + la < n_src) if total is None else (t < total)  # noqa: E731
        while ready(self._n_static, self._n_smooth, self.Ls):
            self._smooth_frame(self._n_smooth)
            self._n_smooth += 1
        while ready(self._n_smooth, self._n_d1, self.Ld):
            self._d1[self._n_d1] = self._delta(self._smooth, self._n_d1)
            self._n_d1 += 1
        rows = []
        while ready(self._n_d1, self._n_out, self.Ld):
            t = self._n_out
            d2 = self._delta(self._d1, t)
            row = [self._smooth[t], self._d1[t], d2]
            if self.voicing:
                row.append(np.array([self._voiced[t]]))
            rows.append(np.concatenate(row))
            self._n_out += 1
        self._forget()
        if not rows:
            return np.zeros((0, len(self.names)))
        return np.stack(rows)

    def _forget(self) -> None:
        """Drop frames and samples no later frame can need (memory stays bounded on long streams)."""
        keep_from = self._n_out - (self.S + 2 * self.Wd + 2)
        for store in (self._static, self._smooth, self._d1, self._voiced):
            for k in [k for k in store if k < keep_from]:
                del store[k]
        first = min(self._start(self._n_static, self.f0_len), self._start(self._n_static, self.win))
        drop = first - self._buf0
        if drop > 4 * self.f0_len:
            self._buf = self._buf[drop:]
            self._buf0 = first

    # -- the interface ---------------------------------------------------------------------------
    def push(self, samples) -> np.ndarray:
        """Add mono samples (float, [-1, 1], at ``sample_rate``); returns the new final frames
        ``(n, D)`` (possibly ``n = 0``)."""
        if self._flushed:
            raise ParameterError("push() after flush(): start a new StreamingF0e for a new stream")
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        if x.size and not np.all(np.isfinite(x)):
            raise ParameterError("pushed audio holds NaN or inf samples; expected finite values in [-1, 1]")
        if x.size:
            self._buf = np.concatenate([self._buf, x])
            self._n_in += x.size
        return self._advance()

    def flush(self) -> np.ndarray:
        """End of stream: the remaining frames, up to ``align.n_frames`` of everything pushed
        (samples past the end count as zeros, end frames repeat in smoothing and Δ)."""
        from ..align import n_frames

        if self._flushed:
            return np.zeros((0, len(self.names)))
        self._total = n_frames(self._n_in, self.sample_rate, self.fps)
        if self._n_out > self._total:  # cannot happen: frames are only final with samples past them
            raise AssertionError("emitted more frames than the stream holds")
        out = self._advance()
        self._flushed = True
        return out


def f0e_live(audio: Audio, *, fps: float, n_frames: int, **params):
    """The ``f0e-live`` feature set: :class:`StreamingF0e` run over the whole file at once (the
    same code path as streaming, so identical values).  Returns ``(values (T, 6|7), names)``."""
    from .frames import fit_length

    ex = StreamingF0e(sample_rate=audio.sample_rate, fps=fps, **params)
    values = np.vstack([ex.push(audio.samples), ex.flush()])
    return fit_length(values, n_frames), list(ex.names)


__all__ = ["StreamingF0e", "f0e_live", "yin_frame", "regression_weights", "NAMES"]
