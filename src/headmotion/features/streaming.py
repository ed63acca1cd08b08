"""Incremental F0 + energy features for low-latency streaming (paper §4.1 "F0+Energy",
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
  (global silence threshold, Viterbi path) and cannot run on a stream; librosa's ``yin`` can be
  called on one window (``center=False``) and computes the same normalised difference, but returns no aperiodicity (so no voicing decision), costs ~4× more
  per call (612 against 169 µs, measured together) and gave 150.23 Hz on a 150 Hz harmonic tone
  where this gives 149.997 Hz; ``pyin`` needs the whole signal for its HMM.
* **Octave-jump guard**: a voiced frame more than ``max_jump_semitones`` (5) from the median of
  the last (up to 5) voiced frames of the last 0.3 s counts as unvoiced — a causal stand-in for
  Praat's path search; on our speech it raises the correlation with Praat on frames both call
  voiced from 0.70–0.998 to 0.93–0.999.
* **Unvoiced frames hold the last voiced log F0** (the causal half of the offline rule "ends hold
  the nearest voiced value"; interpolating towards the *next* voiced frame would need unbounded
  lookahead).  Before the first voiced frame: ``sqrt(floor · ceiling)`` as offline.
* **Smoothing and deltas with short lookahead.**  The 10-frame moving average (paper §4.1) takes
  ``smooth_lookahead`` future frames (default 2; offline: 4) and ``smooth_frames − 1 −
  smooth_lookahead`` past ones.  Δ is the least-squares slope of the line through ``delta_width``
  (5, HTK's N = 2) frames ending ``delta_lookahead`` frames in the future (default 1; offline HTK:
  2) — the same regression weights as HTK, evaluated over a window shifted into the past — and ΔΔ
  is the same slope of Δ.  Indices before the first frame / after the last clip to the end frame.
  Against ``f0e`` this shifts the smoothed streams 20 ms later (window centre 2.5 frames back
  instead of 0.5) and Δ, ΔΔ a further 10 ms each — visible as a small lag in a plot of the two
  (models trained on ``f0e-live`` learn with the lag they will see when streaming).

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

The lookahead of smoothing and Δ is counted in frames, so it costs more at video frame rates:
at 25 fps the defaults need 159 ms; ``smooth_lookahead=0, delta_lookahead=0`` brings that to
39 ms (a causal average and backward-looking slopes: more lag, no lookahead).

Add the push granularity (≤ 10 ms with 10 ms chunks) and the on-stream resampler's delay (0 at
16 kHz in; a few ms through soxr otherwise): ≈ 75–80 ms, leaving ≥ 20 ms of a 100 ms live budget for
the synthesiser (the template-warping generator itself is causal: it adds 0).  ``lookahead_s`` is
exact for any parameters: frame ``t`` is final once the sample ``(t+K+0.5)·sr/fps + W_f/2`` is in,
``K = smooth_lookahead + 2 · delta_lookahead``.

Cost (``benchmarks/run.py --only features,stream``): pushed 10 ms at a time, 0.07 ms of CPU per
chunk (p95 0.12 ms; load average ~3 on this shared 2-core machine); a whole file at once runs at
0.4–0.6× the speed of the Praat-based ``f0e`` measured at the same moment.  Every stage works on a
batch of frames with per-row numpy operations only (one ``np.correlate`` per frame for YIN's
autocorrelation; sums over a window in a fixed order), which is what keeps a frame's value
independent of how the audio was chunked.  A push that completes one to four frames (a stream's
10 ms chunk) takes them one at a time through the same operations on 1-D rows (:func:`yin_row`,
views of the audio and of the stored frames instead of gathers, storage grown geometrically
instead of concatenated): ~40 numpy calls per frame instead of ~150, the same bits
(``tests/test_stream_fast_paths.py``).  numba was not used here: the per-frame numpy path meets the
0.5 ms per chunk budget with room, and the streaming model's CLI start does not pay numba's import
(~0.35 s).

F0 against the offline ``f0e`` on ../shared/data/speech (9 files, first 30 s each, 100 fps):
on the frames both trackers call voiced, log F0 correlates at r = 0.93–0.999 (median |Δ| 0.03–0.12
semitone, ≤ 3 % of frames off by more than a semitone); YIN calls fewer frames voiced (22–61 %
against Praat's 49–66 %).  After the hold and the smoothing, the ``logf0`` columns correlate less
(r 0.07–0.72, median 0.5): Praat's own octave jumps, which the interpolation spreads over pauses,
and the hold-versus-interpolate difference dominate (Praat with a hold instead of interpolation
correlates with itself at only 0.66–0.95); ``energy`` correlates at 0.95–0.99.

:class:`StreamingProsody` (feature set ``"prosody-live"``) does the same for the Le et al. (2012)
baseline's ``prosody`` set: pitch from the same YIN (semitones re 27.5 Hz, or Hz) and openSMILE's
``cIntensity`` loudness, unsmoothed as offline, so only the F0 window is ahead: 24.2 ms.

Used by the systems: tws-basic / tws-hier train and predict with ``f0e-live``
and le2012 with ``prosody-live`` by default; their streams push the model-rate samples through
:class:`headmotion.systems.tws.generator.LiveFeatures` (this extractor at 16 kHz, frames cast to
float32 as :func:`headmotion.features.extract` does), so streamed and offline features are
bit-identical when the audio is at 16 kHz (the models' ``sample_rate``); at another rate
``extract`` resamples the whole file and the live input resamples on the fly, so they differ by the
resampler (soxr) alone.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from ..types import Audio
from .prosody import PITCH_CEILING, PITCH_FLOOR
from .yin import yin_frame, yin_frames, yin_row

NAMES = ["logf0", "energy", "d_logf0", "d_energy", "dd_logf0", "dd_energy"]


def regression_weights(width: int, lookahead: int) -> np.ndarray:  # noqa: ARG001 (the slope does not depend on where the window sits)
    """Weights ``w`` of the least-squares slope over frames ``t − (width − 1 − lookahead) … t +
    lookahead``: ``Δ_t = Σ_k w_k x_{t+k}``.  With ``lookahead = width // 2`` this is HTK's delta
    ``Σ n (x_{t+n} − x_{t−n}) / (2 Σ n²)``."""
    k = np.arange(width, dtype=np.float64)
    k -= k.mean()
    return k / np.sum(k * k)


class _Store:
    """Rows indexed by absolute frame number, the oldest ones forgettable; storage grown
    geometrically, so appending a frame costs O(1) amortised (no copy of the rows held)."""

    def __init__(self, dim: int):
        self.buf = np.zeros((64, dim))
        self.n = 0                # rows used in buf
        self.off = 0              # absolute frame of buf[0]

    @property
    def arr(self) -> np.ndarray:
        return self.buf[:self.n]

    def __len__(self):
        return self.off + self.n

    def _room(self, k: int) -> None:
        if self.n + k > self.buf.shape[0]:
            new = np.zeros((max(2 * self.buf.shape[0], self.n + k), self.buf.shape[1]))
            new[:self.n] = self.buf[:self.n]
            self.buf = new

    def extend(self, rows: np.ndarray) -> None:
        rows = rows.reshape(-1, self.buf.shape[1])
        k = len(rows)
        self._room(k)
        self.buf[self.n:self.n + k] = rows
        self.n += k

    def append(self, *values: float) -> None:
        """One row of scalars (the single-frame path)."""
        self._room(1)
        self.buf[self.n] = values
        self.n += 1

    def take(self, idx: np.ndarray) -> np.ndarray:
        return self.arr[idx - self.off]

    def forget(self, before: int) -> None:
        k = before - self.off
        if k > 256:
            m = max(self.n - k, 0)
            self.buf[:m] = self.buf[k:k + m].copy()
            self.n = m
            self.off = before


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
        self.hamming_sum = float(np.sum(self.hamming))
        self.hamming2 = self.hamming ** 2
        self.hamming2_sum = float(np.sum(self.hamming2))
        self._intensity: _Store | None = None
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
        self._abuf = np.zeros(4096, dtype=np.float64)   # audio storage: _buf = _abuf[:_alen]
        self._alen = 0
        self._buf0 = 0            # absolute index of _buf[0]
        self._n_in = 0            # samples pushed so far
        self._static = _Store(2)            # (log F0 held, energy dB)
        self._voiced = _Store(1)
        self._smooth = _Store(2)
        self._d1 = _Store(2)
        self._last_logf0 = self.default_logf0
        self._recent: list[tuple[int, float]] = []   # (frame, log F0) of the last voiced frames
        self._n_static = 0        # frames with static values
        self._n_smooth = 0
        self._n_d1 = 0
        self._n_out = 0
        self._total: int | None = None   # known at flush
        self._flushed = False
        self._need_next = self._needed(0)   # samples needed before the next frame's static values
        self._k_tau = np.arange(1, self.tau_max + 1, dtype=np.float64)

    @property
    def _empty(self) -> np.ndarray:
        return np.zeros((0, len(self.names)))

    @property
    def _buf(self) -> np.ndarray:
        """The audio held: samples ``_buf0 … _n_in − 1``."""
        return self._abuf[:self._alen]

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

    # -- stages (each computes a batch of frames; every value depends on its own inputs only) ------
    def _windows(self, t0: int, t1: int, length: int) -> np.ndarray:
        """Rows ``[s_t, s_t + length)`` for frames ``t0 … t1−1``; zeros outside the pushed samples."""
        starts = np.floor((np.arange(t0, t1) + 0.5) * self.sample_rate / self.fps - length / 2 + 0.5).astype(np.int64)
        lo, hi = int(starts[0]), int(starts[-1]) + length
        seg = np.zeros(hi - lo)
        a, b = max(lo, self._buf0, 0), min(hi, self._n_in)
        if b > a:
            seg[a - lo:b - lo] = self._buf[a - self._buf0:b - self._buf0]
        if len(starts) == 1:
            return seg[None, :]
        return np.lib.stride_tricks.sliding_window_view(seg, length)[starts - lo]

    def _static_frames(self, t0: int, t1: int) -> None:
        if t1 - t0 <= 4:           # a stream's push: frame by frame, same values as the batch
            for t in range(t0, t1):
                self._static_one(t)
            return
        xe = self._windows(t0, t1, self.win)
        sq = xe * xe
        if self._intensity is not None:  # openSMILE's cIntensity: Hamming-weighted mean of x²
            self._intensity.extend(np.sum(sq * self.hamming, axis=1) / self.hamming_sum)
        p = np.sum(sq * self.hamming2, axis=1) / self.hamming2_sum
        energy = np.maximum(10.0 * np.log10(np.maximum(p, 1e-30)), -100.0)
        # YIN only where a frame is loud enough to be voiced (a quieter one is unvoiced whatever its
        # period; YIN's rows are independent, so a subset gives the same values)
        loud = energy > self.silence_db
        period, ap = np.zeros(t1 - t0), np.ones(t1 - t0)
        if loud.any():
            period[loud], ap[loud] = yin_frames(self._windows(t0, t1, self.f0_len)[loud], self.win, self.tau_min,
                                                self.tau_max, self.threshold)
        logf0 = np.full(t1 - t0, self.default_logf0)
        voiced = (period > 0) & (ap < self.voicing_threshold) & (energy > self.silence_db)
        raw = np.log(self.sample_rate / np.where(voiced, period, 1.0))
        for k in range(t1 - t0):                  # the hold and the octave-jump guard: sequential
            voiced[k] = self._hold(t0 + k, bool(voiced[k]), float(raw[k]))
            logf0[k] = self._last_logf0
        self._static.extend(np.stack([logf0, energy], axis=1))
        self._voiced.extend(voiced.astype(np.float64))

    def _energy_db(self, t0: int, t1: int) -> np.ndarray:
        """Frames ``t0 … t1−1``'s energy (dB, Hamming² weighted, floored at −100) in one batch: the
        energy column of the readers that take their pitch from elsewhere (Praat)."""
        xe = self._windows(t0, t1, self.win)
        p = np.sum(xe * xe * self.hamming2, axis=1) / self.hamming2_sum
        return np.maximum(10.0 * np.log10(np.maximum(p, 1e-30)), -100.0)

    def _hold(self, t: int, voiced: bool, lf: float) -> bool:
        """The hold and the octave-jump guard of frame ``t`` (sequential); returns its voicing."""
        if not voiced:
            return False
        recent = sorted(v for f, v in self._recent if f >= t - self.jump_memory)
        med = 0.0
        if recent:
            m = len(recent)
            med = recent[m // 2] if m % 2 else 0.5 * (recent[m // 2 - 1] + recent[m // 2])
        if self.max_jump > 0 and recent and abs(lf - med) > self.max_jump:
            return False     # an octave-like jump away from the recent voiced frames
        self._recent = [(f, v) for f, v in self._recent if f >= t - self.jump_memory][-4:] + [(t, lf)]
        self._last_logf0 = lf
        return True

    def _frame_window(self, t: int, length: int) -> np.ndarray:
        """Row ``t`` of :meth:`_windows`: a view of the audio when it lies inside what is held."""
        s0 = math.floor((t + 0.5) * self.sample_rate / self.fps - length / 2 + 0.5)
        a = s0 - self._buf0
        if s0 >= 0 and a >= 0 and s0 + length <= self._n_in:
            return self._abuf[a:a + length]
        return self._windows(t, t + 1, length)[0]

    def _static_one(self, t: int) -> None:
        """:meth:`_static_frames` of the one frame ``t``: the same operations on 1-D rows (numpy's
        own log / log10 on scalars, as its vectorised ones give different last bits from ``math``'s)."""
        xe = self._frame_window(t, self.win)
        sq = xe * xe
        if self._intensity is not None:
            self._intensity.append(np.sum(sq * self.hamming) / self.hamming_sum)
        p = np.sum(sq * self.hamming2) / self.hamming2_sum
        energy = max(10.0 * np.log10(p if p > 1e-30 else 1e-30), -100.0)
        voiced = energy > self.silence_db
        if voiced:
            period, ap = yin_row(self._frame_window(t, self.f0_len), self.win, self.tau_min, self.tau_max,
                                 self.threshold, self._k_tau)
            voiced = period > 0 and ap < self.voicing_threshold
        voiced = self._hold(t, voiced, float(np.log(self.sample_rate / period)) if voiced else 0.0)
        self._static.append(self._last_logf0, energy)
        self._voiced.append(1.0 if voiced else 0.0)

    def _window_sum(self, src: _Store, t0: int, t1: int, back: int, ahead: int, weights=None) -> np.ndarray:
        """Σ_k w_k · src[t + k] for k = −back … ahead (w = 1 without weights), indices clipped to
        the stream.  The sum runs over the middle axis of ``(frames, k, dims)``, in k order for
        every frame, so a frame's value does not depend on how many frames are in the batch (one
        frame inside the stream: the same ``(1, k, dims)`` sum over a view instead of a gather)."""
        a = t0 - back - src.off
        if t1 - t0 == 1 and self._total is None and a >= 0 and t0 - back >= 0:
            g = src.buf[a:a + back + ahead + 1][None]
            return (g * weights[None, :, None] if weights is not None else g).sum(axis=1)
        idx = np.arange(t0, t1)[:, None] + np.arange(-back, ahead + 1)[None, :]
        np.maximum(idx, 0, out=idx)
        if self._total is not None:
            np.minimum(idx, self._total - 1, out=idx)
        g = src.arr[idx - src.off]
        if weights is not None:
            g = g * weights[None, :, None]
        return g.sum(axis=1)

    def _static_ready(self) -> int:
        """Frames whose static values can be computed now."""
        if self._total is not None:
            return self._total
        if self._n_in < self._need_next:
            return self._n_static
        t = max(self._n_static, int((self._n_in - self.f0_len) * self.fps / self.sample_rate) - 2)
        while t > self._n_static and self._needed(t - 1) > self._n_in:
            t -= 1
        while self._needed(t) <= self._n_in:
            t += 1
        return t

    def _advance(self, ready: int | None = None) -> np.ndarray:
        """The frames final now; ``ready``: :meth:`_static_ready`, when the caller has it."""
        total = self._total
        t1 = self._static_ready() if ready is None else ready
        if t1 > self._n_static:
            self._static_frames(self._n_static, t1)
            self._n_static = t1
            self._need_next = self._needed(t1)
        def stop(n_src: int, la: int) -> int:  # frames final at a stage whose input has n_src frames
            return n_src - la if total is None else total

        t1 = stop(self._n_static, self.Ls)
        if t1 > self._n_smooth:
            self._smooth.extend(self._window_sum(self._static, self._n_smooth, t1, self.S - 1 - self.Ls, self.Ls) / self.S)
            self._n_smooth = t1
        back = self.Wd - 1 - self.Ld
        t1 = stop(self._n_smooth, self.Ld)
        if t1 > self._n_d1:
            self._d1.extend(self._window_sum(self._smooth, self._n_d1, t1, back, self.Ld, self.w_delta))
            self._n_d1 = t1
        t0, t1 = self._n_out, stop(self._n_d1, self.Ld)
        if t1 <= t0:
            return np.zeros((0, len(self.names)))
        cols = [self._smooth.arr[t0 - self._smooth.off:t1 - self._smooth.off],
                self._d1.arr[t0 - self._d1.off:t1 - self._d1.off],
                self._window_sum(self._d1, t0, t1, back, self.Ld, self.w_delta)]
        if self.voicing:
            cols.append(self._voiced.arr[t0 - self._voiced.off:t1 - self._voiced.off])
        out = np.hstack(cols)    # (a copy: _forget may move the rows the slices view)
        self._n_out = t1
        self._forget()
        return out

    def _first_needed(self) -> int:
        """The first sample a frame not yet analysed can read."""
        return min(self._start(self._n_static, self.f0_len), self._start(self._n_static, self.win), self._n_in)

    def _forget(self) -> None:
        """Drop frames and samples no later frame can need (memory stays bounded on long streams)."""
        keep_from = self._n_out - (self.S + 2 * self.Wd + 2)
        for store in (self._static, self._smooth, self._d1, self._voiced, self._intensity):
            if store is None:
                continue
            store.forget(keep_from)
        first = self._first_needed()
        drop = first - self._buf0        # (at low frame rates the next window may start past the input)
        if drop > 4 * self.f0_len:
            m = max(self._alen - drop, 0)
            self._abuf[:m] = self._abuf[drop:drop + m].copy()
            self._alen = m
            self._buf0 = first

    # -- the interface ---------------------------------------------------------------------------
    def push(self, samples) -> np.ndarray:
        """Add mono samples (float, [-1, 1], at ``sample_rate``); returns the new final frames
        ``(n, D)`` (possibly ``n = 0``)."""
        return self._advance() if self._take(samples) else self._empty

    def _take(self, samples) -> bool:
        """Add ``samples`` to the buffer; whether a frame may be final now."""
        if self._flushed:
            raise ParameterError("push() after flush(): start a new StreamingF0e for a new stream")
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        k = x.size
        if k:
            # a sum of float32-range samples cannot overflow: it is finite iff every sample is
            if not math.isfinite(float(np.add.reduce(x))) and not np.all(np.isfinite(x)):
                raise ParameterError("pushed audio holds NaN or inf samples; expected finite values in [-1, 1]")
            if self._alen + k > len(self._abuf):
                new = np.zeros(max(2 * len(self._abuf), self._alen + k))
                new[:self._alen] = self._abuf[:self._alen]
                self._abuf = new
            self._abuf[self._alen:self._alen + k] = x
            self._alen += k
            self._n_in += k
            if self._n_in < self._need_next and self._total is None:
                return False   # no frame's window is complete yet (most pushes of a few ms)
        return True

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


def whole_file(ex: StreamingF0e, audio: Audio, n_frames: int):
    """A whole file through the incremental extractor ``ex`` (the stream's code path, so the same
    values): ``(values (n_frames, D), names)``, fitted to ``n_frames`` as the feature sets are."""
    from .frames import fit_length

    values = np.vstack([ex.push(audio.samples), ex.flush()])
    return fit_length(values, n_frames), list(ex.names)


def f0e_live(audio: Audio, *, fps: float, n_frames: int, **params):
    """:class:`StreamingF0e` (YIN) run over the whole file at once (the same code path as streaming,
    so identical values); the ``f0e-live`` set with either reader is
    :func:`headmotion.features.readers.f0e_live`.  Returns ``(values (T, 6|7), names)``."""
    return whole_file(StreamingF0e(sample_rate=audio.sample_rate, fps=fps, **params), audio, n_frames)


class StreamingProsody(StreamingF0e):
    """Incremental ``pitch`` and ``loudness`` — the ``prosody`` set of the Le et al. (2012)
    baseline (thesis §2.3, §5.5.1) — from the same YIN F0 (held through unvoiced frames) and
    openSMILE's ``cIntensity`` loudness ``(I / 10⁻⁶)^0.3`` of a 25 ms Hamming window, with no
    smoothing or Δ, so a frame is final once its F0 window is in: 24.2 ms after its start at
    16 kHz and 100 fps.  ``unit="semitone"`` (re 27.5 Hz) or ``"hz"``; the ``loudness="auditory"``
    variant of :func:`headmotion.features.prosody.prosody` is not offered here.
    """

    def __init__(self, *, unit: str = "semitone", exponent: float = 0.3, **kw):
        if unit not in ("semitone", "hz"):
            raise ParameterError(f"prosody unit must be 'semitone' or 'hz'; got {unit!r}")
        for k in ("smooth_frames", "smooth_lookahead", "delta_lookahead", "voicing"):
            if k in kw:
                raise ParameterError(f"prosody-live has no parameter {k!r} (no smoothing, no deltas)")
        super().__init__(smooth_frames=1, smooth_lookahead=0, delta_lookahead=0, **kw)
        self.unit, self.exponent = unit, float(exponent)
        self.names = ["pitch", "loudness"]
        self._intensity = _Store(1)

    def _advance(self) -> np.ndarray:
        t1 = self._static_ready()
        if t1 > self._n_static:
            self._static_frames(self._n_static, t1)
            self._n_static = t1
            self._need_next = self._needed(t1)
        t0, t1 = self._n_out, self._n_static
        if t1 <= t0:
            return np.zeros((0, 2))
        lf = self._static.arr[t0 - self._static.off:t1 - self._static.off, 0]
        pitch = 12.0 * (lf - math.log(27.5)) / math.log(2.0) if self.unit == "semitone" else np.exp(lf)
        loud = (self._intensity.arr[t0 - self._intensity.off:t1 - self._intensity.off, 0] / 1e-6) ** self.exponent
        out = np.stack([pitch, loud], axis=1)
        self._n_out = t1
        self._forget()
        return out


def prosody_live(audio: Audio, *, fps: float, n_frames: int, **params):
    """The ``prosody-live`` feature set: :class:`StreamingProsody` over the whole file (the
    streaming code path).  Returns ``(values (T, 2), ["pitch", "loudness"])``."""
    return whole_file(StreamingProsody(sample_rate=audio.sample_rate, fps=fps, **params), audio, n_frames)


__all__ = ["StreamingF0e", "StreamingProsody", "whole_file", "f0e_live", "prosody_live", "yin_frame", "yin_frames",
           "regression_weights", "NAMES"]
