"""The causal template-warping generator and its stream (thesis §5.8).

The generator starts every axis from the training means, then repeatedly takes the axis whose
current segment ends first, builds its input vector from what has been generated so far and the
speech up to that frame, asks the system for ``(d, a)``, applies the limits and appends the warped
template (:func:`headmotion.motion.templates.template_shape`).  It is causal: frames before the
earliest pending change point are final, which is what :class:`TwsStream` emits.

:meth:`Generator.render_settled` passes the rendered frames, in order, through the system's
post-processing chain (:mod:`.post`: pause settling over the speech flags of the system's causal
detector, :mod:`headmotion.features.speech_activity`; amplitude matching; speed shaping; slow-band
restoration) — causal, so offline synthesis and the stream give the same frames.
"""

from __future__ import annotations

import numpy as np


from ...align import n_frames as _n_frames
from ...features.live import LIVE_SETS as LIVE_FEATURES
from ...features.live import LiveFeatures, live_extractor
from ...motion.post import PostChain
from ...motion.templates import template_shape
from ...types import Audio, Motion
from .limits import Limits
from .post import post_tables


class FeatureFrames:
    """The generator's feature matrix: rows indexed by absolute frame number, storage grown
    geometrically (amortised O(1) per frame) and the oldest rows forgettable, so a long stream holds
    a bounded number of frames.  Indexing (an int, a slice or an index array) is absolute;
    ``len()`` is the number of frames pushed so far."""

    def __init__(self, dim: int):
        self.buf = np.zeros((256, dim))
        self.off = 0       # absolute frame of buf[0]
        self.n = 0         # rows used in buf

    def __len__(self) -> int:
        return self.off + self.n

    @property
    def stored(self) -> int:
        """Rows held in memory (for tests of bounded memory)."""
        return self.buf.shape[0]

    def extend(self, rows: np.ndarray) -> None:
        rows = np.asarray(rows, dtype=np.float64)
        k = len(rows)
        if k == 0:
            return
        if self.n + k > self.buf.shape[0]:
            new = np.zeros((max(2 * self.buf.shape[0], self.n + k), self.buf.shape[1]))
            new[:self.n] = self.buf[:self.n]
            self.buf = new
        self.buf[self.n:self.n + k] = rows
        self.n += k

    def forget(self, before: int) -> None:
        """Drop the frames before ``before`` (absolute); storage shrinks back when mostly empty."""
        k = min(before - self.off, self.n)
        if k < 256:
            return
        keep = self.buf[k:self.n]
        cap = self.buf.shape[0]
        if self.n - k < cap // 4 and cap > 1024:
            cap = max(1024, 2 * (self.n - k))
        new = np.zeros((cap, self.buf.shape[1]))
        new[:self.n - k] = keep
        self.buf, self.off, self.n = new, self.off + k, self.n - k

    def _rel(self, idx):
        if isinstance(idx, slice):
            start, stop, step = idx.indices(len(self))
            if start < self.off:
                raise IndexError(f"feature frame {start} was forgotten (oldest kept: {self.off})")
            return slice(start - self.off, max(stop, start) - self.off, step)
        if isinstance(idx, (int, np.integer)):
            i = int(idx) + (len(self) if idx < 0 else 0)
            if not self.off <= i < len(self):
                raise IndexError(f"feature frame {int(idx)} not held (frames {self.off}..{len(self) - 1})")
            return i - self.off
        idx = np.asarray(idx)
        if idx.size and (idx.min() < self.off or idx.max() >= len(self)):
            raise IndexError(f"feature frames {idx.min()}..{idx.max()} not held (frames {self.off}..{len(self) - 1})")
        return idx - self.off

    def __getitem__(self, idx):
        return self.buf[:self.n][self._rel(idx)]


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
        self.F = FeatureFrames(system.n_features_)
        #: feature frames before a change point that ``_choose`` may read (hier: its HMM window)
        self.memory = int(getattr(system, "feature_memory", 0))
        self.n_segs = [1, 1, 1]  # segments ever made per axis (the template alternates with it)
        self.rendered = 0
        self.ctx = system._init_generation()
        self.soft = bool(getattr(system, "soft_limit", False))
        self.settled = 0
        #: the post-processing chain (:func:`.post.post_tables`) and the speech tracker its
        #: settling reads (None without settling)
        self.chain = PostChain(post_tables(system, fps))
        det = getattr(system, "speech_detector_", None)
        self.detector = det.start() if self.chain.tables.settles else None
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
        self.F.extend(F_new)

    def forget(self) -> None:
        """Drop the features and segments no later change point or frame can need (streaming:
        memory and time per chunk stay bounded however long the stream runs)."""
        first = min(self.settled if self.detector is not None else self.rendered, int(self.next_change.min()))
        if first - self.F.off < 512:
            return
        self.F.forget(first - self.memory - 1)
        # segments that end before the next frame to render (the last one per axis stays)
        for j in range(3):
            segs = self.segs[j]
            k = 0
            while k < len(segs) - 1 and segs[k + 1][0] <= self.rendered:
                k += 1
            if k > 8:
                del segs[:k]

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
            template = 1 if s > 0 or (s == 0 and self.n_segs[j] % 2 == 0) else 0
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
            self.n_segs[j] += 1
            self.next_change[j] = t + n_new
        return int(self.next_change.min())

    def render(self, a: int, b: int) -> np.ndarray:
        """Frames [a, b) of all axes, (b-a, 3)."""
        if b <= a:
            return np.empty((0, 3))
        tt = np.arange(a, b, dtype=np.float64)
        rows = np.empty((b - a, 3, 4))      # (start, n, s, c) of the segment holding each frame
        for j in range(3):
            segs = self.segs[j]
            i = len(segs) - 1          # only the segments from the one holding frame a on
            while i > 0 and segs[i][0] > a:
                i -= 1
            arr = np.asarray(segs[i:], dtype=np.float64)
            if len(arr) == 1:
                rows[:, j] = arr[0]
            else:
                k = np.searchsorted(arr[:, 0], tt, side="right") - 1
                rows[:, j] = arr[np.maximum(k, 0)]
        ph = np.minimum(np.maximum((tt[:, None] - rows[..., 0]) / rows[..., 1], 0.0), 1.0)
        return rows[..., 3] + rows[..., 2] * template_shape(ph)

    def render_one(self, a: int) -> list[float]:
        """Frame ``a`` of all axes: :meth:`render` of one frame with the same operations on
        scalars (numpy's cos on the three phases)."""
        fa = float(a)
        ph, rows = [], []
        for j in range(3):
            segs = self.segs[j]
            i = len(segs) - 1
            while i > 0 and segs[i][0] > a:
                i -= 1
            st, n, s, c = segs[i]
            rows.append((float(s), float(c)))
            ph.append(min(max((fa - float(st)) / float(n), 0.0), 1.0))
        shape = 0.5 * (1.0 - np.cos(np.pi * np.array(ph)))
        return [c + s * float(k) for (s, c), k in zip(rows, shape)]

    @property
    def _stateful(self) -> bool:
        return not self.chain.identity

    def render_settled(self, a: int, b: int) -> np.ndarray:
        """Frames [a, b) after settling in pauses and speed shaping; calls must cover the utterance
        in order (``a`` = the previous call's ``b``) and the features of frames < b must be pushed."""
        x = self.render(a, b)
        self.rendered = max(self.rendered, b)
        if not self._stateful or b <= a:
            return x
        if a != self.settled:
            raise RuntimeError(f"render_settled: frames must come in order (expected {self.settled}, got {a})")
        self.settled = b
        flags = self.detector.push(self.F[a:b]) if self.detector is not None else None
        return self.chain.push(x, flags)

    def render_settled_one(self, a: int) -> list[float]:
        """Frame ``a`` through the chain (:meth:`render_settled` of ``[a, a + 1)``) on scalars."""
        x = self.render_one(a)
        self.rendered = max(self.rendered, a + 1)
        if not self._stateful:
            return x
        if a != self.settled:
            raise RuntimeError(f"render_settled: frames must come in order (expected {self.settled}, got {a})")
        self.settled = a + 1
        return self.chain.push_one(x, self._flag_one(a) if self.detector is not None else True)

    def _flag_one(self, a: int) -> bool:
        """The speech flag of frame ``a`` (the tracker's one-frame path once it is warm)."""
        row = self.F.buf[a - self.F.off]
        tracker = self.detector
        if tracker.n >= tracker.update_frames - 1:
            d = tracker.det
            return tracker.push_one_db((float(row[d.col]) * d.sd + d.mu) * d.db_per_unit)
        return bool(tracker.push(row[None])[0])


class TwsStream:
    """Streaming synthesis: push float samples at the model's ``sample_rate`` (any chunk size),
    get the frames that became final.

    Live feature sets (``f0e-live``, the default of new models): the features come from
    :class:`headmotion.features.streaming.StreamingF0e` pushed with every chunk, and the generator
    is causal (a change point at frame ``t`` reads features up to ``t``; frames before the earliest
    pending change point are final), so the algorithmic latency is the features' own: 64.2 ms at
    100 fps (``latency_ms``; the generator holds nothing back).  The output equals offline
    ``predict`` of the same 16 kHz audio exactly (same feature values, same generator, same random
    draws).

    Model files with a whole-utterance feature set (``f0e``) keep the
    blocked extraction: a block of ``feature_block`` frames plus ``feature_context`` frames of right
    context must be in before its change points are processed, so the latency is ``(feature_block
    + feature_context) / fps`` (0.7 s with the defaults); their offline ``predict`` equals the
    stream with ``blocked=True``.

    Memory and time per chunk are bounded over any length: consumed audio is dropped, the
    generator keeps only the feature frames and segments it can still read (:meth:`Generator.forget`)
    and renders only the new frames.  A push that completes one frame (a 10 ms chunk) renders,
    flags, weighs and settles it on scalars (:meth:`Generator.render_settled_one`, equal to the
    batch code): ~0.14 ms of CPU per chunk with the features (``benchmarks/run.py --only stream``;
    the mean includes the change points, whose choice of the next segment costs up to ~0.7 ms)."""

    def __init__(self, system, *, seed: int | None):
        self.sys = system
        self.fps = system.fps_
        self.sr = system.sample_rate_
        self.gen = Generator(system, rng=np.random.default_rng(seed), fps=self.fps)
        self.emitted = 0
        cfg = system._config()
        self.live = cfg.name in LIVE_FEATURES
        if self.live:
            self.feats = LiveFeatures(cfg, self.sr)
            self.latency_ms = self.feats.latency_ms
            self.normalizer = system.normalizer_
            return
        self.buf = np.zeros(0, dtype=np.float32)
        self.buf0 = 0                      # absolute sample index of buf[0]
        self.block = system.feature_block
        self.ctx = system.feature_context
        self.next_block = 0
        self.latency_ms = 1000.0 * (self.block + self.ctx) / self.fps

    # -- blocked (whole-utterance feature sets) -------------------------------------------------
    def _frames_in_buffer(self) -> int:
        return _n_frames(self.buf0 + len(self.buf), self.sr, self.fps)

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
                                          start_block=self.next_block, stop_frame=min(f1, T),
                                          sample_offset=self.buf0)
            self.gen.push_features(F)
            self.next_block += 1
        # drop the audio no later block reads (its left context starts here)
        first = int(round(max(0, self.next_block * self.block - self.ctx) * self.sr / self.fps))
        if first - self.buf0 > 4 * self.sr:
            self.buf = self.buf[first - self.buf0:].copy()
            self.buf0 = first

    # -- the interface ----------------------------------------------------------------------------
    def push(self, samples) -> Motion:
        x = np.asarray(samples, dtype=np.float32).ravel()
        if self.live:
            self._push_features(self.feats.push(x))
        else:
            self.buf = np.concatenate([self.buf, x]) if len(self.buf) else x.copy()
            self._extract_ready(final=False)
        ready = self.gen.run()
        return self._emit(min(ready, len(self.gen.F)))

    def flush(self) -> Motion:
        if self.live:
            self._push_features(self.feats.flush())
            T = len(self.gen.F)
        else:
            self._extract_ready(final=True)
            T = self._frames_in_buffer()
        self.gen.run()
        return self._emit(T)

    def _push_features(self, F: np.ndarray) -> None:
        if len(F):
            self.gen.push_features(np.asarray(self.normalizer.transform(F), dtype=np.float64))

    def _emit(self, upto: int) -> Motion:
        a, b = self.emitted, max(self.emitted, upto)
        rv = np.array([self.gen.render_settled_one(a)]) if b == a + 1 else self.gen.render_settled(a, b)
        self.emitted = b
        self.gen.forget()
        return Motion(rv, self.fps)


__all__ = ["Generator", "FeatureFrames", "TwsStream", "LiveFeatures", "LIVE_FEATURES", "live_extractor"]
