"""Safety limits of template-warping synthesis, learned from the training data (the thesis is
silent on limits; chosen so generated motion never jumps and stays in a head's range).

Durations are clipped to ``[min segment, 99.5th percentile of training]``; amplitudes to the
training maximum, to the fastest per-frame change seen in (smoothed) training data (a half-cosine
of amplitude ``a`` over ``n`` frames changes by at most ``pi a / (2 n)`` per frame), and so that
the segment's end stays within the training range widened by 10 % on each side.

Soft limit (``soft=True``; issue 14, diagnosis §3.4 — not in the thesis, which had no limits): before
the hard clip, a segment that moves *away* from the training mean pose has its amplitude scaled by
``max(0, 1 - (c - mean) / (edge - mean))``, ``c`` the current position and ``edge`` the training
maximum (rising) or minimum (falling).  At the mean nothing changes; the nearer the head is to the
edge of the training range, the smaller the excursions away from the mean, while moves back towards
it are free — a pull back towards the mean pose.  Sampled amplitudes alone otherwise random-walk
the head to the clip limits and pin it there (tws-basic on ZEGGS: 2–7 % of frames saturated;
tws-hier on the whole ZEGGS take: yaw pinned at +35–40° for 20 s).  ``soft=False`` is the literal
behaviour.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...motion.segmentation import min_segment_frames, smooth
from .vectors import AxisData


@dataclass
class Limits:
    """Per-axis limits learned from the training data (see the module docstring)."""

    d_min: float            # seconds
    d_max: np.ndarray       # (3,) seconds
    a_max: np.ndarray       # (3,) radians
    v_max: np.ndarray       # (3,) radians per frame
    lo: np.ndarray          # (3,) radians
    hi: np.ndarray
    mean: np.ndarray        # (3,) mean position
    d_mean: np.ndarray      # (3,)
    a_mean: np.ndarray      # (3,)

    @classmethod
    def from_training(cls, motions, data: list[AxisData], fps: float) -> "Limits":
        allr = np.vstack(motions)
        sm = [smooth(m, fps=fps) for m in motions]
        v = np.max(np.vstack([np.abs(np.diff(s, axis=0)) for s in sm if len(s) > 1]), axis=0)
        d_max, a_max, d_mean, a_mean = [], [], [], []
        for j in range(3):
            y = np.asarray(data[j].y).reshape(-1, 2)
            if len(y) == 0:
                y = np.array([[0.3, 0.0]])
            d_max.append(np.percentile(y[:, 0], 99.5))
            a_max.append(np.max(y[:, 1]))
            d_mean.append(y[:, 0].mean())
            a_mean.append(y[:, 1].mean())
        lo, hi = allr.min(axis=0), allr.max(axis=0)
        return cls(d_min=min_segment_frames(fps) / fps, d_max=np.asarray(d_max), a_max=np.asarray(a_max),
                   v_max=v, lo=lo, hi=hi, mean=allr.mean(axis=0), d_mean=np.asarray(d_mean),
                   a_mean=np.asarray(a_mean))

    def to_arrays(self) -> dict:
        return {f"lim_{k}": np.asarray(getattr(self, k), dtype=np.float64) for k in self.__dataclass_fields__}

    @classmethod
    def from_arrays(cls, arrays) -> "Limits":
        kw = {k: np.asarray(arrays[f"lim_{k}"], dtype=np.float64) for k in cls.__dataclass_fields__}
        kw["d_min"] = float(kw["d_min"])
        return cls(**kw)

    def soften(self, j: int, a: float, c: float, sign: float) -> float:
        """The amplitude after the soft limit (module docstring) for a segment from ``c`` in
        direction ``sign`` (+1 rising, -1 falling)."""
        dev = c - self.mean[j]
        edge = self.hi[j] if sign > 0 else self.lo[j]
        room = edge - self.mean[j]
        if sign * dev <= 0 or sign * room <= 0:  # moving towards the mean (or no room measured)
            return a
        return a * max(0.0, 1.0 - dev / room)

    def clip(self, j: int, d: float, a: float, c: float, sign: float, fps: float, *,
             soft: bool = False) -> tuple[int, float]:
        """Frames and signed amplitude of a new segment after applying the limits (with ``soft``,
        the soft limit first)."""
        n = int(round(min(max(d, self.d_min), max(self.d_max[j], self.d_min)) * fps))
        n = max(n, 1)
        if soft:
            a = self.soften(j, max(a, 0.0), c, sign)
        a = min(max(a, 0.0), self.a_max[j], 2.0 * n * self.v_max[j] / math.pi)
        span = self.hi[j] - self.lo[j]
        lo, hi = self.lo[j] - 0.1 * span, self.hi[j] + 0.1 * span
        end = min(max(c + sign * a, lo), hi)
        s = end - c
        if s * sign < 0:  # already beyond the range in this direction: hold
            s = 0.0
        return n, s


__all__ = ["Limits"]
