"""The template-warping systems' post-processing tables (a chain of :mod:`headmotion.motion.post`
in :data:`~headmotion.motion.post.chain.TEMPLATE_ORDER`: pause settling, amplitude matching, speed
shaping, slow-band restoration; ``docs/decisions/post-chain.md``)."""

from __future__ import annotations

import numpy as np

from ...motion.bands import BAND_EDGES_HZ
from ...motion.post import TEMPLATE_ORDER, PostTables
from ...motion.post.restore import gv_ratio

#: largest slow-band gain of ``slow_band_restore``
SLOW_BAND_CAP = 2.0
#: ``amplitude_match``'s gains lie in [1 / AMPLITUDE_CAP, AMPLITUDE_CAP]
AMPLITUDE_CAP = 2.0


def amplitude_gains(synthesis, heads, *, cap: float = AMPLITUDE_CAP) -> np.ndarray:
    """Per-axis gains ``(D,)`` of ``amplitude_match``: the heads' SD over the synthesis's, both
    pooled within recordings (:func:`~headmotion.motion.post.restore.gv_ratio`), bounded to
    [1 / ``cap``, ``cap``].  ``synthesis`` and ``heads`` are lists of ``(T_k, D)`` arrays paired by
    recording."""
    return np.maximum(gv_ratio(synthesis, heads, cap=float(cap)), 1.0 / float(cap))


def slow_band_bank(var_synthesis, var_heads, *, cap: float = SLOW_BAND_CAP) -> np.ndarray:
    """Gains ``(2, D)`` of ``slow_band_restore``: row 0 for the slow band, row 1 for every faster
    band, from per-band variances ``(B, D)`` of the synthesis and of the heads (band 0 the slowest).
    The slow gain moves the synthesis's share of power in the slow band onto the heads' share,
    ``sqrt(share_heads / share_synthesis)`` bounded to [1, ``cap``]; the faster bands' common gain
    ``sqrt((1 − g² share_synthesis) / (1 − share_synthesis))`` keeps the total variance, so the
    stage changes the spectrum's shape and not the amplitude (which the templates set)."""
    vp = np.asarray(var_synthesis, dtype=np.float64)
    vt = np.asarray(var_heads, dtype=np.float64)
    sp = vp[0] / np.maximum(vp.sum(axis=0), 1e-18)
    st = vt[0] / np.maximum(vt.sum(axis=0), 1e-18)
    g = np.where(sp > 1e-12, np.sqrt(st / np.maximum(sp, 1e-12)), 1.0)
    g = np.clip(g, 1.0, float(cap))
    rest = np.sqrt(np.clip(1.0 - g ** 2 * sp, 0.0, None) / np.maximum(1.0 - sp, 1e-12))
    return np.stack([g, np.minimum(rest, 1.0)])


def band_bank(gains) -> np.ndarray:
    """The per-band gains ``(B, D)`` of a :func:`slow_band_bank`: row 0 for the slowest band, row 1
    repeated for every faster one."""
    g = np.asarray(gains, dtype=np.float64).reshape(2, -1)
    return np.vstack([g[:1], np.repeat(g[1:], len(BAND_EDGES_HZ), axis=0)])


def post_tables(system, fps: float) -> PostTables:
    """The chain's tables of a fitted template system: settling when it has a speech detector and
    ``idle`` < 1, amplitude gains (``amplitude_match``), the speed map (``speed_shaping``), the slow
    band's gains (``slow_band_restore``), each when the model has the table."""
    det = getattr(system, "speech_detector_", None)
    idle = float(getattr(system, "idle", 1.0))
    table = getattr(system, "speed_map_", None)
    gains = getattr(system, "slow_band_gains_", None)
    amp = getattr(system, "amplitude_gains_", None)
    use_amp = getattr(system, "amplitude_match", False) and amp is not None
    return PostTables(
        fps=float(fps), order=TEMPLATE_ORDER,
        idle=idle if det is not None else None,
        amplitude_gains=np.asarray(amp, dtype=np.float64) if use_amp else None,
        amplitude_centre=system.limits_.mean if use_amp else None,
        speed_map=table if getattr(system, "speed_shaping", False) else None,
        band_gains=band_bank(gains) if getattr(system, "slow_band_restore", False) and gains is not None else None)


__all__ = ["amplitude_gains", "slow_band_bank", "band_bank", "post_tables", "SLOW_BAND_CAP", "AMPLITUDE_CAP"]
