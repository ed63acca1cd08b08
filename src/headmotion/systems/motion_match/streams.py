"""The streams of a motion-match model: audio pushed in, frames out as ``predict`` gives them."""

from __future__ import annotations

import numpy as np

from ...align import fit_length
from ...align import n_frames as _n_frames
from ...types import Motion
from ..decisions import run_alone, steps_of
from .library import FPS, LIVE_NAMES
from .walk import _Walk


def _tail_rows(last: np.ndarray | None, raw: np.ndarray, n: int) -> np.ndarray:
    """The feature rows still to come at a stream's end, ``n`` of them, as ``predict``'s features
    are fitted to the audio's length: ``raw`` trimmed, or padded by repeating its last row — or,
    when ``raw`` is empty, the last row seen before (``last``; None when nothing was seen)."""
    if last is None:
        return fit_length(raw, n)
    return fit_length(np.concatenate([last[None], raw]), n + 1)[1:]


class MotionMatchStream:
    """:meth:`MotionMatch.stream` (``live`` models): push float samples at the model's
    ``sample_rate``; a frame is final once the f0e-live features of the frame ``lookahead_ms``
    later (A = :attr:`MotionMatch._shift` frames) are (``latency_ms``: 39 ms at 16 kHz + A · 40 ms),
    and the frames equal ``predict``'s.  Every ``hop`` frames a decision is made from the prosody
    so far (up to its frame + A) and its frames are emitted as the features A frames after them
    arrive; at the end the last prosody row stands for the A rows past it, as in ``predict``.
    State: the feature extractor, the last frames of prosody a decision reads, the take's walk — bounded."""

    def __init__(self, model, *, seed: int):
        self.m = model
        self.ex = model._feature_stream()
        self.ahead = model._shift  # frames of prosody read past a frame before it is emitted
        self.latency_ms = self.ex.latency_ms + 1000.0 * self.ahead / FPS
        self.walk = _Walk(model, seed)
        self.back = model._live_back
        self.cols = [list(self.ex.names).index(n) for n in LIVE_NAMES]  # the matched columns, by name
        self.past = np.zeros((0, len(LIVE_NAMES)), np.float32)
        self.pending = np.zeros((0, 3))
        self.k = 0            # frames emitted
        self.rows = 0         # feature rows read (the frames emitted + ahead, once that many came)
        self.samples = 0      # samples pushed
        self.raw_last = None  # the last raw feature row (repeated if the file ends before its frames)

    def _frames(self, raw: np.ndarray):
        """The frames ``raw``'s feature rows make final — a generator of the decisions' asks
        (:meth:`push_steps`), returning the Motion."""
        m, H = self.m, int(self.m.hop)
        if not len(raw):  # most 10 ms pushes finish no frame (25 a second)
            return Motion(np.zeros((0, 3)), FPS)
        out = np.zeros((len(raw), 3))
        n = 0
        for row in raw:
            f = m.standardised(row[self.cols])
            self.past = np.concatenate([self.past, f[None]])[-self.back:]
            self.rows += 1
            if self.rows <= self.ahead:  # frame 0's decision reads this far ahead
                continue
            if self.k % H == 0:  # a decision: its hop of frames, as rotation vectors at once
                ask = self.walk.ask(*m.live_inputs(self.past), H)
                row = (yield ask) if ask.query is not None else None
                self.pending = m._degrees_to_motion(self.walk.answer(ask, row)).rotvec
            out[n] = self.pending[self.k % H]
            self.k += 1
            n += 1
        self.raw_last = raw[-1]
        return Motion(out[:n], FPS)

    def push(self, samples: np.ndarray) -> Motion:
        return run_alone(self.push_steps(samples))

    def push_steps(self, samples: np.ndarray):
        """:meth:`push` step by step: a generator that yields each decision's
        :class:`~.walk.Ask` and is sent the library's costs for it, and its pitch reader's
        :class:`~headmotion.features.praat_path.Read` and is sent the candidates (a batched engine
        answers many streams' asks at once, :func:`~headmotion.systems.decisions.run_alone` each
        alone); returns the Motion."""
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        self.samples += len(x)
        return (yield from self._frames((yield from steps_of(self.ex, "push", x))))

    def flush(self) -> Motion:
        """The remaining frames: as many in all as ``predict`` gives for the audio pushed."""
        return run_alone(self.flush_steps())

    def flush_steps(self):
        """:meth:`flush` step by step (as :meth:`push_steps`)."""
        raw = np.asarray(self.ex.flush()).reshape(-1, len(self.ex.names))
        total = _n_frames(self.samples, int(self.m.sample_rate_), FPS)
        rows = _tail_rows(self.raw_last, raw, max(total - self.rows, 0))
        last = rows[-1:] if len(rows) else (None if self.raw_last is None else self.raw_last[None])
        pad = max(total + self.ahead - self.rows - len(rows), 0)  # rows past the end the last frames read
        if pad and last is not None:  # the last row repeated, as predict reads them
            rows = np.concatenate([rows, np.repeat(last, pad, 0)])
        return (yield from self._frames(rows))


class WindowStream:
    """:meth:`MotionMatch.stream` for models on the f0e-live prosody that read ahead (not ``live``):
    push float samples at the model's ``sample_rate``; a decision is made once the prosody of its
    window (:attr:`MotionMatch._reach`) is final, and its hop of frames is emitted then, so a frame
    comes ``latency_ms`` after its start (the features' 39 ms and the window's reach ahead, about
    1.1 s by default).  The frames equal ``predict``'s: the same windows, the same decisions.
    State: the feature extractor, the prosody rows a decision can still read, the take's walk."""

    def __init__(self, model, *, seed: int):
        self.m = model
        self.ex = model._feature_stream()
        self.back, self.ahead = model._reach
        self.latency_ms = self.ex.latency_ms + 1000.0 * self.ahead / FPS
        self.walk = _Walk(model, seed)
        self.cols = [list(self.ex.names).index(n) for n in LIVE_NAMES]  # the matched columns, by name
        self.rows = np.zeros((0, len(LIVE_NAMES)), np.float32)  # standardised prosody from frame row0
        self.row0 = 0
        self.t = 0            # the next decision's frame
        self.samples = 0      # samples pushed
        self.raw_last = None  # the last raw feature row (repeated if the file ends before its frames)

    def _add(self, raw: np.ndarray) -> None:
        if len(raw):
            m = self.m
            f = m.standardised(np.asarray(raw)[:, self.cols])
            self.rows = np.concatenate([self.rows, f])
            self.raw_last = raw[-1]

    def _decide(self, total: int | None):
        """Every decision whose window is final: all rows to ``t + ahead`` are known and will be
        in the file (fewer than the frames of the samples pushed), or ``total`` (the file's frames)
        is known — a generator of the decisions' asks, returning the Motion."""
        H, out = int(self.m.hop), []
        known = self.row0 + len(self.rows)
        while self.t < (total if total is not None else 0) or (
                total is None and self.t + self.ahead < min(known, _n_frames(self.samples, int(self.m.sample_rate_), FPS))):
            lo = max(0, self.t - self.back)
            window = self.rows[lo - self.row0:self.t + self.ahead + 1 - self.row0]
            n = H if total is None else min(H, total - self.t)
            ask = self.walk.ask(*self.m.window_inputs(window, self.t - lo), n)
            row = (yield ask) if ask.query is not None else None
            out.append(self.walk.answer(ask, row))
            self.t += H
        keep = max(0, self.t - self.back) - self.row0  # rows no later decision reads
        if keep > 0:
            self.rows, self.row0 = self.rows[keep:], self.row0 + keep
        return self.m._degrees_to_motion(np.vstack(out) if out else np.zeros((0, 3)))

    def push(self, samples: np.ndarray) -> Motion:
        return run_alone(self.push_steps(samples))

    def push_steps(self, samples: np.ndarray):
        """:meth:`push` step by step (as :meth:`MotionMatchStream.push_steps`)."""
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        self.samples += len(x)
        self._add((yield from steps_of(self.ex, "push", x)))
        return (yield from self._decide(None))

    def flush(self) -> Motion:
        """The remaining frames: as many in all as ``predict`` gives for the audio pushed."""
        return run_alone(self.flush_steps())

    def flush_steps(self):
        """:meth:`flush` step by step."""
        raw = np.asarray(self.ex.flush()).reshape(-1, len(self.ex.names))
        total = _n_frames(self.samples, int(self.m.sample_rate_), FPS)
        have = self.row0 + len(self.rows)
        self._add(_tail_rows(self.raw_last, raw, total if self.raw_last is None else max(total - have, 0)))
        self.rows = self.rows[:max(total - self.row0, 0)]
        return (yield from self._decide(total))
