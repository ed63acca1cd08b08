"""The post-processing chain's tables of the DNN systems, fitted after the networks
(``docs/decisions/post-chain.md``, ``cross-fitting.md``, ``speed-shaping.md``):

* the within-recording SD and the global variance ratio of the network output on the training
  frames (:func:`~headmotion.motion.post.restore.gv_ratio`);
* the per-band gains: the geometric mean of those measured on the training frames and on the
  validation frames (an over-fitted network is livelier on its training frames than on new speech,
  so the training frames' gains under-restore; the validation frames' are unbiased but noisy);
* the speed map: on the validation frames' output of the restoring stages, or (``cross_fit``) on
  the output of two half models each trained on the other half's speakers — new speakers, as at
  synthesis.
"""

from __future__ import annotations

import numpy as np

from ...motion.post import PostChain
from ...motion.post import restore
from ...motion.post import speed_shaping
from ..base import cross_fitted, pair_shortest
from . import inference
from .data import held_out_views
from .synthesis import post_tables
from .training import torch_context


def restoration_tables(system, train, valid, reg, pf) -> tuple[np.ndarray, np.ndarray, np.ndarray, list, list]:
    """``(motion_sd, gv, band_gains, held-out outputs, held-out targets)`` of the trained networks."""
    seg = int(system.segment)
    with torch_context(0, system.n_threads):
        raw = [inference.network_output(reg, pf, p.r, segment=seg) for p in train]
    motion_sd = restore.within_sd([p.y for p in train])
    gv = restore.gv_ratio(raw, [p.y for p in train])
    with torch_context(0, system.n_threads):
        held = [(inference.network_output(reg, pf, r, segment=seg), y, s) for r, y, s in held_out_views(train, valid)]
    hraw, hy, hs = [h[0] for h in held], [h[1] for h in held], [h[2] for h in held]
    fps = float(system.model_fps)
    g_train = restore.band_gains(raw, [p.y for p in train], fps=fps)
    g_valid = restore.band_gains(hraw, hy, fps=fps, starts=hs)
    return motion_sd, gv, np.sqrt(g_train * g_valid), hraw, hy


def speed_max_gain(system, *, cross: bool) -> float:
    """The speed map's largest speed-up: ``speed_max_gain``, or by default
    :data:`~headmotion.motion.post.speed_shaping.WIDE_SPEED_MAX_GAIN` for a cross-fitted map
    (``cross``) and :data:`~headmotion.motion.post.speed_shaping.SPEED_MAX_GAIN` for the validation
    frames' map."""
    g = system.speed_max_gain
    if g is not None:
        return float(g)
    return float(speed_shaping.WIDE_SPEED_MAX_GAIN if cross else speed_shaping.SPEED_MAX_GAIN)


def validation_speed_map(system, raw, targets) -> np.ndarray:
    """The speed map of the restoring stages' output (recording k's drift drawn with seed k; no
    pauses) against the motion, both rotation vectors at the model rate."""
    tables = post_tables(system).only("restore", "denormalise")
    norm = system.motion_norm_
    pred, targ = [], []
    for k, (y, t) in enumerate(zip(raw, targets)):
        pred.append(PostChain(tables, seed=k).push(np.asarray(y, dtype=np.float64)))
        targ.append(np.asarray(norm.inverse_transform(t), dtype=np.float64))
    return speed_shaping.speed_map(pred, targ, lag=speed_shaping.shaping_lag(system.model_fps),
                                   max_gain=speed_max_gain(system, cross=False))


def cross_fit_speed_map(system, recs) -> np.ndarray:
    """``cross_fit``: the speed map fitted on the restoring stages' output (no pauses, no range
    limit) of two half models of the same parameters, each trained on the speakers of the other
    half (:func:`~headmotion.systems.base.cross_fitted` with ``by_speaker``; recordings when there
    is one speaker), against the recorded heads at the model rate."""
    mfps = float(system.model_fps)
    off = {"speed_shaping": False, "idle": None, "range_limit": False, "cross_fit": False}
    pred = cross_fitted(system, recs, off, lambda half, r, k: half._predict(r.audio, seed=k).rotvec, by_speaker=True)
    targ = [np.asarray(r.motion.resample(mfps).rotvec) for r in recs]
    pred, targ = pair_shortest(pred, targ)
    return speed_shaping.speed_map(pred, targ, lag=speed_shaping.shaping_lag(mfps),
                                   max_gain=speed_max_gain(system, cross=True))


__all__ = ["restoration_tables", "speed_max_gain", "validation_speed_map", "cross_fit_speed_map"]
