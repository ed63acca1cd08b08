"""Streaming synthesis for the DNN systems: the offline pipeline computed on a rolling window of
audio, a frame emitted only when every value it depends on is the one the whole-file computation
gives.  The seeds are silent on streaming (paper §3 is offline).

* **features** of frame ``f`` (frame convention of :mod:`headmotion.features.frames`) need audio up
  to sample ``f · hop + right`` (:func:`feature_reach`): ``mfcc`` 920 samples at 16 kHz (the
  25 ms window, 17.5 ms past the frame's start, plus ±4 frames of Δ and ΔΔ), ``fbank`` 280,
  ``wav`` 280 + 160 (the 25 ms window and a 10 ms margin for the 16 → 4 kHz soxr filter),
  ``f0e`` 200 ms (Praat's window, the 10-frame smoothing and the deltas — approximate, see below);
* the **regressor** output at frame ``v`` needs features ``v − context … v + context`` (±25);
* the **post-filter** (50-frame segments every 25 frames, Hann overlap-add) makes frames
  ``25 k … 25 k + 24`` final when the segment starting at ``25 k`` has its 50 regressor outputs:
  frames are emitted 25 at a time.

So a frame at time ``τ`` is final once the audio reaches ``τ + latency``, with the worst case (the
first frame of a 25-frame block) ``latency_ms = 1000 · (segment − 1 + context) / fps + right / sr``:
797.5 ms for mfcc-dnn, 767.5 ms for cccae / ae-dnn / wav-dnn (wav), 757.5 ms for fbank-dnn,
940 ms for f0e-dnn at the defaults (``context + 1000 · right / sr`` ms without the post-filter).
Per block, only the new work is done: the regressor outputs are cached by frame, the features of
the new ones are computed on a window of audio starting ``context + left`` frames before them, and
the post-filter runs on the segments that cover the block, on the offline 25-frame grid.

What follows the networks is the post-processing chain of :mod:`.synthesis`, causal and with
state, the very objects ``predict`` uses, so the stream equals ``predict``: bit for bit in all but
the networks' float32 arithmetic in other batch sizes (≤ 2e-8 rad for mfcc / fbank); ``wav``
features resampled by soxr from the window agree to ≤ 2e-7 rad; ``f0e`` (f0e-dnn) is approximate —
Praat's pitch path search uses the whole window, so a frame's F0 can still change beyond 200 ms.

Library considered: none streams an arbitrary windowed pipeline with exact frame alignment; the
window bookkeeping is a few lines here.
"""

from __future__ import annotations

import math

import numpy as np

from ...align import n_frames as count_frames
from ...errors import ParameterError
from ...types import Audio, Motion
from . import inference
from .synthesis import frame_energy_db

def feature_reach(config, sample_rate: int, fps: float) -> tuple[int, int]:
    """``(right, left)``: samples of audio beyond a frame's start that its features need (right),
    and frames before it that they depend on (left)."""
    hop = sample_rate / fps
    p = dict(config.params or {})
    win = int(round(float(p.get("window_s", 0.025)) * sample_rate))
    half_right = int(math.ceil(hop / 2 + win / 2))
    name = config.name
    if name == "mfcc":
        d = 4 if p.get("deltas", True) else 0
        right = int(d * hop) + half_right
    elif name == "fbank":
        right = half_right
    elif name == "wav":
        right = half_right + int(round(0.010 * sample_rate))
    elif name == "f0e":
        right = int(round(0.200 * sample_rate))
    else:
        raise ParameterError(f"streaming is not defined for the {name!r} feature set (mfcc, fbank, wav, f0e)")
    left = int(math.ceil(right / hop)) + 2
    return right, left


class DnnStream:
    """A :class:`~headmotion.systems.base.MotionStream` for a fitted DNN system (module docstring)."""

    def __init__(self, system, *, seed: int | None):
        self.sys = system
        self.sr = int(system.sample_rate_)
        self.fps = float(system.model_fps)
        hop = self.sr / self.fps
        if abs(hop - round(hop)) > 1e-9:
            raise ParameterError(f"{system.name} streams only when sample_rate / model_fps is a whole number "
                                 f"of samples; got {self.sr} / {self.fps:g}")
        self.hop = int(round(hop))
        self.ctx = int(system.context)
        self.seg = int(system.segment) if system.postfilter_ is not None else 1
        self.block = max(1, self.seg // 2) if system.postfilter_ is not None else 1
        self.right, self.left = feature_reach(system.feature_config_, self.sr, self.fps)
        self.latency_ms = 1000.0 * ((self.seg - 1) + self.ctx) / self.fps + 1000.0 * self.right / self.sr
        self.post = system._post(seed)
        self.buf = np.zeros(0, dtype=np.float32)
        self.buf0 = 0        # utterance sample index of buf[0]
        self.n_in = 0        # samples received
        self.emitted = 0     # frames emitted
        self.reg = np.zeros((0, 3), dtype=np.float32)  # regressor outputs of frames reg0 … reg_end − 1
        self.reg0 = 0
        self.reg_end = 0
        self.done = False

    # -- bookkeeping ---------------------------------------------------------------------------
    def _final_frames(self) -> int:
        """Frames whose every dependency is in the audio received so far."""
        if self.n_in < self.right:
            return 0
        f_ok = (self.n_in - self.right) // self.hop + 1          # exact feature frames
        r_ok = f_ok - self.ctx                                    # exact regressor frames
        if r_ok < self.seg:
            return 0
        return self.block * ((r_ok - self.seg) // self.block + 1)

    def _regress(self, end: int, T: int | None) -> None:
        """Extend the cache of regressor outputs to frames ``< end`` (``T``: the utterance's
        length at flush, for the end's edge padding; None mid-stream)."""
        from ...models import numpy_nets as nets  # padding rules without torch

        if end <= self.reg_end:
            return
        v0, ctx = self.reg_end, self.ctx
        fa = max(0, v0 - ctx - self.left)                       # first frame of the audio window
        x = self.buf[fa * self.hop - self.buf0:]
        # mid-stream: every frame the audio holds (the deltas of the last needed frames need the
        # static features of the next ones; the window's own last frames are not used)
        fb = max(end + ctx, fa + count_frames(len(x), self.sr, self.fps)) if T is None else T
        feats = self.sys._extract(Audio(x, self.sr), fb - fa)
        # the features of frames v0 − ctx … end + ctx − 1, padded outside [0, T) as offline
        # (mirrored; mid-stream only the start is padded, every later frame the windows use exists)
        idx = np.arange(v0 - ctx, end + ctx)
        idx = nets.pad_indices(idx, T if T is not None else fb, nets.SYNTHESIS_PAD) - fa
        F = np.asarray(feats, dtype=np.float32)[idx]
        self.sys._check_features(F, "the feature track")
        y = inference.regress_windows(self.sys.regressor_, self.sys._regressor_input(F), end - v0)
        self.reg = np.concatenate([self.reg, y]) if len(self.reg) else y
        self.reg_end = end

    def _run(self, upto: int, T: int | None) -> np.ndarray:
        """Frames ``emitted … upto − 1`` (``T``: the utterance's length at flush)."""
        e = self.emitted
        if self.sys.postfilter_ is not None:
            # the post-filter blocks covering e … upto − 1 start at e − hop … (offline grid)
            end = (upto - self.block + self.seg) if T is None else T
            self._regress(end, T)
            s = max(0, e - self.block)
            seq = self.reg[s - self.reg0: end - self.reg0]
            y = inference.postfilter(self.sys.postfilter_, seq, segment=self.seg)[e - s: upto - s]
        else:
            self._regress(upto, T)
            y = self.reg[e - self.reg0: upto - self.reg0]
        en = None
        if self.post.needs_energy:
            sf = max(0, e - 1)
            sub = self.buf[sf * self.hop - self.buf0:]
            en = frame_energy_db(sub, sample_rate=self.sr, fps=self.fps, n_frames=upto - sf)[e - sf:]
        rv = self.post.push(np.asarray(y, dtype=np.float64), en)
        self.emitted = upto
        # drop what no later block needs: regressor outputs before the next first block, audio
        # before the next feature window and the next energy window
        r_keep = max(0, upto - self.block) if self.sys.postfilter_ is not None else upto
        if r_keep > self.reg0:
            self.reg = self.reg[r_keep - self.reg0:]
            self.reg0 = r_keep
        keep = min(max(0, self.reg_end - self.ctx - self.left), max(0, upto - 1)) * self.hop
        if keep > self.buf0:
            self.buf = self.buf[keep - self.buf0:]
            self.buf0 = keep
        return rv

    def _motion(self, rv: np.ndarray) -> Motion:
        return Motion(np.asarray(rv, dtype=np.float64).reshape(-1, 3), self.fps, meta={"system": self.sys.name})

    # -- the MotionStream interface ------------------------------------------------------------
    def push(self, samples) -> Motion:
        if self.done:
            raise ParameterError("this stream was flushed; start a new one with model.stream()")
        x = np.asarray(samples, dtype=np.float32).ravel()
        if len(x) and not np.all(np.isfinite(x)):
            raise ParameterError(f"audio pushed to the {self.sys.name} stream contains NaN or inf samples")
        self.buf = np.concatenate([self.buf, x]) if len(self.buf) else x.copy()
        self.n_in += len(x)
        upto = self._final_frames()
        if upto <= self.emitted:
            return self._motion(np.zeros((0, 3)))
        with inference.threads(self.sys.n_threads):
            return self._motion(self._run(upto, None))

    def flush(self) -> Motion:
        if self.done:
            return self._motion(np.zeros((0, 3)))
        self.done = True
        T = count_frames(self.n_in, self.sr, self.fps)
        if T <= self.emitted:
            return self._motion(np.zeros((0, 3)))
        with inference.threads(self.sys.n_threads):
            return self._motion(self._run(T, T))


__all__ = ["DnnStream", "feature_reach"]
