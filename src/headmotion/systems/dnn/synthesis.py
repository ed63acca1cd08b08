"""What the DNN systems do after the networks (offline and on a stream alike): the post-processing
chain of :mod:`headmotion.motion.post` in :data:`~headmotion.motion.post.chain.DNN_ORDER`, with the
speech flags its pause settling reads from the frames' energy.

The chain's tables come from the fitted system (:func:`post_tables`): per-band gains (the slowest
band's times ``slow_band_gain``) when ``restore_bands`` and the model has them, else the global
variance ratio; the posture drift (``drift_share``, ``drift_tau_s``, seeded by the synthesis seed);
the model's normaliser; the speed map (``speed_shaping``); the soft range (``range_limit``); the
idle level (``idle``) with the pull towards the mean pose in pauses when shaping
(:data:`PAUSE_PULL`).
"""

from __future__ import annotations

import numpy as np

from ...features.speech_activity import SpeechDetector
from ...motion.post import DNN_ORDER, PostChain, PostTables

#: analysis window of the pause detector's energy (s)
ENERGY_WINDOW_S = 0.025
#: pull (1/s) towards the training mean pose inside pauses when the speed shaper is on: the
#: restored slow band can leave the head far out when speech stops
PAUSE_PULL = 0.3


def frame_energy_db(samples: np.ndarray, *, sample_rate: int, fps: float, n_frames: int) -> np.ndarray:
    """Mean power (dBFS) of the 25 ms window centred on each of the first ``n_frames`` frames
    (zeros outside the signal): the pause detector's input."""
    from ...features.frames import frame_log_energy_db  # a chunk of windows at a time

    win = max(2, int(round(ENERGY_WINDOW_S * sample_rate)))
    return frame_log_energy_db(np.asarray(samples, dtype=np.float32), sample_rate=sample_rate, fps=fps,
                               n_frames=n_frames, win_length=win)


def post_tables(system) -> PostTables:
    """The post-processing chain's tables of a fitted DNN system (module docstring)."""
    bands = getattr(system, "band_gains_", None)
    use_bands = bool(system.variance_restore and system.restore_bands and bands is not None)
    if use_bands:
        bands = np.asarray(bands, dtype=np.float64).copy()
        bands[0] *= float(system.slow_band_gain)
    table = getattr(system, "speed_map_", None)
    bounds = getattr(system, "range_", None)
    mean = system.motion_norm_.mean_
    return PostTables(
        fps=float(system.model_fps), order=DNN_ORDER,
        band_gains=bands if use_bands else None,
        gv=system.gv_ if system.variance_restore and not use_bands else None,
        drift_share=float(system.drift_share), drift_sd=system.motion_sd_, drift_tau_s=float(system.drift_tau_s),
        norm_mean=mean, norm_sd=system.motion_norm_.std_,
        idle=system.idle, pause_pull=PAUSE_PULL if system.speed_shaping else 0.0,
        pause_pose=np.asarray(mean, dtype=np.float64),
        speed_map=table if system.speed_shaping else None,
        range_bounds=bounds if getattr(system, "range_limit", False) else None, range_centre=mean)


class DnnPost:
    """The chain with its speech detector: ``push(y, energy_db)`` takes normalised network output
    ``(n, 3)`` and the frames' energies (dBFS; None: no pause settling) and returns rotation vectors."""

    def __init__(self, tables: PostTables, *, seed: int | None):
        self.chain = PostChain(tables, seed=seed)
        self.needs_energy = tables.settles
        if self.needs_energy:
            det = SpeechDetector(col=0, mu=0.0, sd=1.0, db_per_unit=1.0, fps=float(tables.fps))
            self.tracker = det.start()

    def push(self, y: np.ndarray, energy_db: np.ndarray | None) -> np.ndarray:
        flags = None
        if self.needs_energy and energy_db is not None and len(y):
            flags = self.tracker.push(np.asarray(energy_db, dtype=np.float64)[:, None])
        return self.chain.push(np.asarray(y, dtype=np.float64), flags)


__all__ = ["DnnPost", "post_tables", "frame_energy_db", "ENERGY_WINDOW_S", "PAUSE_PULL"]
