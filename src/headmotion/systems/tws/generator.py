"""The causal template-warping generator and its stream (thesis §5.8).

The generator starts every axis from the training means, then repeatedly takes the axis whose
current segment ends first, builds its input vector from what has been generated so far and the
speech up to that frame, asks the system for ``(d, a)``, applies the limits and appends the warped
template (:func:`headmotion.motion.templates.template_shape`).  It is causal: frames before the
earliest pending change point are final, which is what :class:`TwsStream` emits.

Pauses (issue 14 §3): :meth:`Generator.render_settled` passes the rendered frames, in order, through
:class:`headmotion.motion.pauses.PauseSettler` with weights from
:class:`headmotion.motion.pauses.CausalPauseWeight` over the system's speech detector
(:mod:`.speech`) — causal, so offline synthesis and the stream give the same frames.
"""

from __future__ import annotations

import numpy as np

from ...align import n_frames as _n_frames
from ...motion.pauses import CausalPauseWeight, PauseSettler
from ...motion.templates import template_shape
from ...types import Audio, Motion
from .limits import Limits


class Generator:
    """Causal template-warping synthesis over a growing feature matrix.

    ``system`` supplies ``_choose(j, template, state, F, t, rng) -> (d, a)``; the generator
    keeps the per-axis segment lists and renders frames."""

    def __init__(self, system, *, rng: np.random.Generator, fps: float):
        self.sys = system
        self.rng = rng
        self.fps = fps
        lim: Limits = system.limits_
        self.segs = [[] for _ in range(3)]  # (start_frame, n_frames, s, c)
        self.next_change = np.zeros(3, dtype=np.int64)
        self.F = np.zeros((0, system.n_features_))
        self.rendered = 0
        self.ctx = system._init_generation()
        self.soft = bool(getattr(system, "soft_limit", False))
        det = getattr(system, "speech_detector_", None)
        idle = float(getattr(system, "idle", 1.0))
        self.settled = 0
        if det is not None and idle < 1.0:
            self.detector = det.start()
            self.weigher = CausalPauseWeight(fps=fps)
            self.settler = PauseSettler(fps=fps, idle=idle)
        else:
            self.detector = None
        for j in range(3):
            n, s = lim.clip(j, lim.d_mean[j], lim.a_mean[j], lim.mean[j] - lim.a_mean[j] / 2, 1.0, fps,
                            soft=self.soft)
            c = lim.mean[j] - s / 2
            self.segs[j].append((0, n, s, c))
            self.next_change[j] = n

    def axis_state(self, j: int):
        st, n, s, c = self.segs[j][-1]
        return st, n, s, c

    def push_features(self, F_new: np.ndarray) -> None:
        if len(F_new):
            self.F = np.vstack([self.F, F_new]) if len(self.F) else np.asarray(F_new, dtype=np.float64)

    def run(self) -> int:
        """Process change points whose speech is available; return the number of final frames."""
        avail = len(self.F)
        while True:
            j = int(np.argmin(self.next_change))
            t = int(self.next_change[j])
            if t >= avail:  # the speech frame at the change point is not here (yet, or ever)
                break
            st, n, s, c = self.segs[j][-1]
            c_new = c + s
            template = 1 if s > 0 or (s == 0 and len(self.segs[j]) % 2 == 0) else 0
            sign = 1.0 if template == 0 else -1.0
            others = []
            for i in range(3):
                if i != j:
                    _, ni, si, _ = self.segs[i][-1]
                    others += [ni / self.fps, abs(si)]
            state = dict(prev=np.array([n / self.fps, abs(s), c_new]), others=np.array(others),
                         seg_start=st, gen=self.ctx)
            d, a = self.sys._choose(j, template, state, self.F, t, self.rng)
            n_new, s_new = self.sys.limits_.clip(j, d, a, c_new, sign, self.fps, soft=self.soft)
            self.segs[j].append((t, n_new, s_new, c_new))
            self.next_change[j] = t + n_new
        return int(self.next_change.min())

    def render(self, a: int, b: int) -> np.ndarray:
        """Frames [a, b) of all axes, (b-a, 3)."""
        out = np.empty((max(b - a, 0), 3))
        if b <= a:
            return out
        tt = np.arange(a, b, dtype=np.float64)
        for j in range(3):
            arr = np.asarray(self.segs[j], dtype=np.float64)
            starts, ns, ss, cs = arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3]
            k = np.searchsorted(starts, tt, side="right") - 1
            k = np.clip(k, 0, len(arr) - 1)
            ph = np.clip((tt - starts[k]) / ns[k], 0.0, 1.0)
            out[:, j] = cs[k] + ss[k] * template_shape(ph)
        return out


    def render_settled(self, a: int, b: int) -> np.ndarray:
        """Frames [a, b) after settling in pauses; calls must cover the utterance in order
        (``a`` = the previous call's ``b``) and the features of frames < b must be pushed."""
        x = self.render(a, b)
        if self.detector is None or b <= a:
            return x
        if a != self.settled:
            raise RuntimeError(f"render_settled: frames must come in order (expected {self.settled}, got {a})")
        self.settled = b
        w = self.weigher.push(self.detector.push(self.F[a:b]))
        return self.settler.push(x, w)


class TwsStream:
    """Streaming synthesis: push 16-bit-scaled float samples (any chunk size), get final frames.

    Latency: a feature block (``feature_block`` frames) plus its right context must be complete
    before its change points can be processed, so the algorithmic latency is
    ``(feature_block + feature_context) / fps`` seconds at most (0.7 s with the defaults)."""

    def __init__(self, system, *, seed: int | None):
        self.sys = system
        self.fps = system.fps_
        self.sr = system.sample_rate_
        self.gen = Generator(system, rng=np.random.default_rng(seed), fps=self.fps)
        self.buf = np.zeros(0, dtype=np.float32)
        self.block = system.feature_block
        self.ctx = system.feature_context
        self.next_block = 0
        self.emitted = 0
        self.latency_ms = 1000.0 * (self.block + self.ctx) / self.fps

    def _frames_in_buffer(self) -> int:
        return _n_frames(len(self.buf), self.sr, self.fps)

    def _extract_ready(self, final: bool) -> None:
        T = self._frames_in_buffer()
        while True:
            f0 = self.next_block * self.block
            f1 = f0 + self.block
            if f0 >= T:
                break
            if not final and f1 + self.ctx > T - 1:
                break
            F = self.sys._features_blocks(Audio(self.buf, self.sr), T if final else f1 + self.ctx,
                                          start_block=self.next_block, stop_frame=min(f1, T))
            self.gen.push_features(F)
            self.next_block += 1

    def push(self, samples) -> Motion:
        x = np.asarray(samples, dtype=np.float32).ravel()
        self.buf = np.concatenate([self.buf, x])
        self._extract_ready(final=False)
        ready = self.gen.run()
        return self._emit(min(ready, len(self.gen.F)))

    def flush(self) -> Motion:
        self._extract_ready(final=True)
        T = self._frames_in_buffer()
        self.gen.run()
        return self._emit(T)

    def _emit(self, upto: int) -> Motion:
        a, b = self.emitted, max(self.emitted, upto)
        rv = self.gen.render_settled(a, b)
        self.emitted = b
        return Motion(rv, self.fps)


__all__ = ["Generator", "TwsStream"]
