"""Training vectors of template warping at every change point (thesis §5.4–5.7).

At frame ``t`` where axis ``j`` starts a new segment ``k``:

* ``y``        — the new segment's warping parameters ``(d, a)``: duration in seconds, amplitude
  ``a = |s|`` in radians (the template, rising or falling, alternates and is not predicted);
* ``prev``     — the previous segment of this axis ``(d, a)`` and the offset ``c`` (the current
  position; part of the warping parameters ``λ = (d, a, c)``);
* ``others``   — the current segments' ``(d, a)`` of the two other axes at time ``t``;
* speech       — the feature frame at the change (``F[t]``), the 10 frames before it
  (``F[t-9 … t]``, §5.7.2), and the frames of the previous segment (HMM observations, §5.7.4).

Segmentation is :func:`headmotion.motion.segmentation.segment` (thesis §5.2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...motion.segmentation import segment

CONTEXT = 10  # speech frames before the change (thesis §5.7.2)
MAX_HMM_FRAMES = 60  # previous-segment frames scored by the HMMs (the most recent ones)


@dataclass
class AxisData:
    """Training vectors of one axis, one row per change point (segments after the first)."""

    y: list = field(default_factory=list)        # (d, a)
    prev: list = field(default_factory=list)     # (d_prev, a_prev, c)
    others: list = field(default_factory=list)   # (d, a) of the other two axes' current segments
    frame: list = field(default_factory=list)    # F[t]
    ctx: list = field(default_factory=list)      # F[t-9..t] flattened
    template: list = field(default_factory=list)  # 0 rising, 1 falling
    rec: list = field(default_factory=list)       # recording index
    seg_frames: list = field(default_factory=list)  # previous segment's frames (L, D)

    def arrays(self):
        D = len(self.frame[0]) if self.frame else 0
        return dict(
            y=np.asarray(self.y, dtype=np.float64).reshape(-1, 2),
            prev=np.asarray(self.prev, dtype=np.float64).reshape(-1, 3),
            others=np.asarray(self.others, dtype=np.float64).reshape(-1, 4),
            frame=np.asarray(self.frame, dtype=np.float64).reshape(-1, D),
            ctx=np.asarray(self.ctx, dtype=np.float64).reshape(-1, D * CONTEXT),
            template=np.asarray(self.template, dtype=np.int64),
            rec=np.asarray(self.rec, dtype=np.int64),
        )


def context_frames(F: np.ndarray, t: int) -> np.ndarray:
    """F[t-9 … t] (edge-padded at the start), flattened."""
    idx = np.clip(np.arange(t - CONTEXT + 1, t + 1), 0, len(F) - 1)
    return F[idx].ravel()


def segment_motion(rotvec: np.ndarray, fps: float, *, min_swing: float = 0.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per axis: boundaries (K+1,) and smoothed values at them (:func:`~headmotion.motion.segmentation.segment`;
    ``min_swing`` in radians, 0 = the thesis's segmentation)."""
    rv = np.asarray(rotvec, dtype=np.float64)
    out = []
    for j in range(3):
        s = segment(rv[:, j], fps=fps, min_swing=min_swing)
        out.append((s.bounds, s.values))
    return out


def current_segment_params(bounds: np.ndarray, values: np.ndarray, t: int, fps: float) -> tuple[float, float]:
    """(d, a) of the segment of another axis in progress at frame t."""
    if len(bounds) < 2:
        return 0.0, 0.0
    k = int(np.searchsorted(bounds, t, side="right")) - 1
    k = min(max(k, 0), len(bounds) - 2)
    return (bounds[k + 1] - bounds[k]) / fps, abs(values[k + 1] - values[k])


def collect(motions: list[np.ndarray], feats: list[np.ndarray], fps: float, *, with_frames: bool = False,
            min_swing: float = 0.0):
    """Training vectors for the three axes from aligned motions (T, 3) and features (T, D);
    ``min_swing`` (radians) as in :func:`segment_motion`."""
    data = [AxisData() for _ in range(3)]
    for r, (rv, F) in enumerate(zip(motions, feats)):
        segs = segment_motion(rv, fps, min_swing=min_swing)
        for j in range(3):
            b, v = segs[j]
            for k in range(1, len(b) - 1):
                t = int(b[k])
                s = v[k + 1] - v[k]
                dj = data[j]
                dj.y.append(((b[k + 1] - b[k]) / fps, abs(s)))
                dj.prev.append(((b[k] - b[k - 1]) / fps, abs(v[k] - v[k - 1]), v[k]))
                o = []
                for i in range(3):
                    if i != j:
                        o.extend(current_segment_params(segs[i][0], segs[i][1], t, fps))
                dj.others.append(o)
                dj.frame.append(F[t])
                dj.ctx.append(context_frames(F, t))
                dj.template.append(0 if s >= 0 else 1)
                dj.rec.append(r)
                if with_frames:
                    lo = max(int(b[k - 1]), t - MAX_HMM_FRAMES + 1)
                    dj.seg_frames.append(F[lo:t + 1])
    return data


__all__ = ["AxisData", "collect", "context_frames", "current_segment_params", "segment_motion", "CONTEXT",
           "MAX_HMM_FRAMES"]
