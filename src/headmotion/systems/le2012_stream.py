"""The stream of :class:`headmotion.systems.le2012.Le2012`: the causal ascent frame by frame on the
``prosody-live`` features, then the post-processing chain, equal to offline ``predict``."""

from __future__ import annotations

import numpy as np

from ..types import Motion
from ..features.live import LiveFeatures


class Le2012Stream:
    """:meth:`Le2012.stream`: push float samples at the model's ``sample_rate``; every frame is
    final once its ``prosody-live`` features are (``latency_ms``, 24.2 ms at 100 fps), and the
    frames equal offline ``predict``'s (module docstring).  State: the feature extractor, the last
    two frames, the noise generator, the speech tracker, the pause settler and the post stages — bounded.

    Cost per 10 ms chunk (one frame; ``benchmarks/run.py --only stream``): ~0.15 ms of CPU (0.23 ms
    with ``post_restore``'s band split and speed shaper) — the
    features ~0.06, the compiled conditioning and ascent, then the speech flag, pause weight,
    settling and Euler → rotation vector on scalars (the one-frame paths of
    :mod:`headmotion.motion.post`, :mod:`headmotion.features.speech_activity` and
    :func:`headmotion.rotations.pitch_yaw_roll_to_rotvec_one`, equal to the batch code).  The
    numba kernels are loaded when the stream starts (~0.5 s for the first stream of a process), not
    on its first frame."""

    def __init__(self, model, *, seed: int | None):
        self.m = model
        self.fps = model.fps_
        self.feats = LiveFeatures(model._config(), model.sample_rate_)
        self.latency_ms = self.feats.latency_ms
        self.rng = np.random.default_rng(None if seed is None else int(seed))
        self.pull, self.pose, _ = model._start_terms(0, seed)
        self.scale = float(model.start_sd) * float(model.z_mu_[3])
        self.t = 0                        # frames produced so far
        self.last = np.zeros((0, 3))      # the last (up to) two frames, before settling
        self.settle = model._settle()
        self.chain = model._post_chain(model._idle_value() if self.settle else None, self.pose)
        if self.settle:
            self.tracker = model._speech_tracker()
            self.db_scale = 10.0 / float(dict(model._config().params).get("exponent", 0.3))
        if model.compiled:  # load (or compile) the kernels now, not on the first frame (~0.6 s)
            _, stacked = model._cond_rows(np.zeros((1, len(model.z_mu_) - 5)), pad=2)
            model._ascend(np.zeros((3, 3)), None, stacked, self.pull, self.pose, np.zeros((3, 3)))

    def _frames(self, F_raw: np.ndarray) -> Motion:
        n = len(F_raw)
        if n == 0:
            return Motion(np.zeros((0, 3)), self.fps)
        m = self.m
        jitter = self.scale * self.rng.standard_normal((n, 3)) if m.start_sd else np.zeros((n, 3))
        k = min(n, max(0, 2 - self.t))    # the utterance's first two frames are the start pose
        x = np.empty((n, 3))
        x[:k] = m.start_
        hist = self.last if k == 0 else np.vstack([self.last, x[:k]])[-2:]
        if n > k:
            # rows: the two frames before (history), then the new frames
            cond, stacked = m._cond_rows(F_raw[k:], pad=2)
            out = np.empty((n - k + 2, 3))
            out[:2] = hist
            jit = np.zeros((n - k + 2, 3))
            jit[2:] = jitter[k:]
            m._ascend(out, cond, stacked, self.pull, self.pose, jit)
            x[k:] = out[2:]
            hist = out[-2:]
        self.last = np.array(hist, dtype=np.float64)
        self.t += n
        if n == 1:  # a 10 ms push: the settling and the rotation on scalars (same values)
            flag = self._speech_one(float(F_raw[0, 1])) if self.settle else True
            return Motion(np.array([self.chain.push_one(x[0].tolist(), flag)]), self.fps)
        flags = self.tracker.push_db(m._loudness_db(F_raw)) if self.settle else None
        return Motion(self.chain.push(x, flags), self.fps)

    def _speech_one(self, loudness: float) -> bool:
        """The speech flag of one frame from its raw loudness (:meth:`Le2012._loudness_db` on a scalar)."""
        if self.tracker.n < self.tracker.update_frames - 1:
            return bool(self.tracker.push_db(self.m._loudness_db(np.array([[0.0, loudness]])))[0])
        db = self.db_scale * float(np.log10(loudness if loudness >= 1e-30 else 1e-30)) - 60.0
        return self.tracker.push_one_db(db if db >= -100.0 else -100.0)

    def push(self, samples) -> Motion:
        return self._frames(self.feats.push(np.asarray(samples, dtype=np.float32).ravel()))

    def flush(self) -> Motion:
        return self._frames(self.feats.flush())


__all__ = ["Le2012Stream"]
