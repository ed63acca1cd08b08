"""A soft range limit: keep a head inside the range of the heads it was trained on (a stage of the
post-processing chain, :mod:`headmotion.motion.post`; neither seed has one — the paper's DNN output is small, the thesis's templates have their
own clip in :mod:`headmotion.systems.tws.limits`).

Per axis, the deviation ``d`` of each frame from a centre (the training mean pose) passes
unchanged up to a knee ``k`` and is compressed beyond it towards an asymptote ``L``::

    |d| <= k:  d
    |d| >  k:  sign(d) · (k + (L − k) · tanh((|d| − k) / (L − k)))

continuous with slope 1 at the knee, so motion inside the range is untouched and a trajectory
that would leave it bends smoothly towards ``L`` instead of stopping.  Memoryless, so it is the
same offline and on a stream.  :func:`range_from_training` takes the knee at the 99th percentile
of the training heads' deviations from their pooled mean and the asymptote at their largest
deviation plus 10 % of it (the margin the template systems' clip allows).

Why: the default model (mfcc-dnn, trained on video-derived heads) tilted its head by up to 24° on
the ZEGGS take's speech, out of the domain it was trained on, where no training head tilts more
than 19° (5 % of its frames beyond the training heads' 99.9th percentile; the eight other unseen
speech files: none).

Library considered: numpy's ``tanh``; no library has a per-axis soft knee for trajectories.
"""

from __future__ import annotations

import numpy as np

#: percentile of the training deviations where compression starts, and the asymptote's margin
KNEE_PERCENTILE = 99.0
LIMIT_MARGIN = 0.1


def range_from_training(motions, centre) -> np.ndarray:
    """``(2, D)``: knee and asymptote of each axis from the training motions ``(T_i, D)`` about
    ``centre`` (module docstring)."""
    dev = np.abs(np.vstack([np.asarray(m, dtype=np.float64) for m in motions]) - np.asarray(centre, dtype=np.float64))
    knee = np.percentile(dev, KNEE_PERCENTILE, axis=0)
    limit = np.maximum(dev.max(axis=0) * (1.0 + LIMIT_MARGIN), knee * (1.0 + LIMIT_MARGIN))
    return np.stack([knee, limit])


def soft_range(x, centre, bounds) -> np.ndarray:
    """``x`` ``(T, D)`` with each axis's deviation from ``centre`` softly limited by ``bounds``
    (``(2, D)``: knee, asymptote; module docstring)."""
    x = np.asarray(x, dtype=np.float64)
    c = np.asarray(centre, dtype=np.float64)
    knee, limit = np.asarray(bounds, dtype=np.float64)
    d = x - c
    a = np.abs(d)
    span = np.maximum(limit - knee, 1e-12)
    over = a > knee
    if not over.any():
        return x.copy()
    squeezed = knee + span * np.tanh((a - knee) / span)
    return c + np.sign(d) * np.where(over, squeezed, a)


__all__ = ["range_from_training", "soft_range", "KNEE_PERCENTILE", "LIMIT_MARGIN"]
