"""Safety limits of template-warping synthesis, learned from the training data (the thesis is
silent on limits; chosen so generated motion never jumps and stays in a head's range).

Durations are clipped to ``[min segment, 99.5th percentile of training]``; amplitudes to the
training maximum, to the fastest per-frame change seen in (smoothed) training data (a half-cosine
of amplitude ``a`` over ``n`` frames changes by at most ``pi a / (2 n)`` per frame), and so that
the segment's end stays within the training range widened by 10 % on each side.

Fast moves take time (not in the thesis): a large, short segment is *lengthened*
until its peak speed ``pi a / (2 n)`` is at most ``v_fast``, the 99.9th percentile of the
smoothed training motion's per-frame change per axis (at most to the longest duration), before the
amplitude clip above.  Real heads make large turns more slowly than small ones; with the
amplitude clip alone at the training maximum (one frame, an outlier: yaw 1.67 °/frame at 100 fps
on the video corpus against 1.20 at the 99.9th percentile) the streaming default turned 6–9° in
40–50 ms between held postures, a visible snap (largest step 1.94 → 1.27 °/frame on scott's unseen
speech, frames above 1 °/frame 28 → 11 of 2,870; recorded video heads: 0.25 % of frames).  Held out, the
targets are unchanged on the video corpus; on the ZEGGS take tws-hier's pooled spectral L1 and
speed Hellinger fall (0.274 → 0.182, 0.156 → 0.109) and its SD ratios rise (pitch to 1.51: the
amplitudes are no longer cut).  Model files without ``v_fast`` keep the old clip.

Soft limit (``soft=True``; not in the thesis, which had no limits): before
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


#: percentile of the training motion's per-frame change above which a segment is lengthened
FAST_PERCENTILE = 99.9


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
    v_fast: np.ndarray | None = None   # (3,) radians per frame: lengthen faster segments (docstring)

    @classmethod
    def from_training(cls, motions, data: list[AxisData], fps: float) -> "Limits":
        allr = np.vstack(motions)
        sm = [smooth(m, fps=fps) for m in motions]
        steps = np.vstack([np.abs(np.diff(s, axis=0)) for s in sm if len(s) > 1])
        v = np.max(steps, axis=0)
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
                   a_mean=np.asarray(a_mean), v_fast=np.percentile(steps, FAST_PERCENTILE, axis=0))

    def to_arrays(self) -> dict:
        return {f"lim_{k}": np.asarray(getattr(self, k), dtype=np.float64) for k in self.__dataclass_fields__
                if getattr(self, k) is not None}

    @classmethod
    def from_arrays(cls, arrays) -> "Limits":
        kw = {k: np.asarray(arrays[f"lim_{k}"], dtype=np.float64) for k in cls.__dataclass_fields__
              if f"lim_{k}" in arrays}
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
        n_cap = max(int(round(max(self.d_max[j], self.d_min) * fps)), 1)
        n = max(min(int(round(max(d, self.d_min) * fps)), n_cap), 1)
        if soft:
            a = self.soften(j, max(a, 0.0), c, sign)
        if self.v_fast is not None and self.v_fast[j] > 0:  # fast moves take time (module docstring)
            a = min(max(a, 0.0), self.a_max[j])
            n = max(n, min(int(math.ceil(math.pi * a / (2.0 * self.v_fast[j]) - 1e-9)), n_cap))
        a = min(max(a, 0.0), self.a_max[j], 2.0 * n * self.v_max[j] / math.pi)
        span = self.hi[j] - self.lo[j]
        lo, hi = self.lo[j] - 0.1 * span, self.hi[j] + 0.1 * span
        end = min(max(c + sign * a, lo), hi)
        s = end - c
        if s * sign < 0:  # already beyond the range in this direction: hold
            s = 0.0
        return n, s


__all__ = ["Limits", "FAST_PERCENTILE"]
