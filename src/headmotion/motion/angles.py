"""A recording's head motion as the matching and generative systems read it: pitch, yaw and roll in
degrees at a fixed frame rate, the recording's mean pose removed (docs/decisions/motion-matching.md,
generative-system.md)."""

from __future__ import annotations

import numpy as np

from ..rotations import rotvec_to_pitch_yaw_roll
from ..types import Motion


def centred_degrees(motion: Motion, n: int, fps: float) -> np.ndarray:
    """``(n, 3)`` pitch, yaw, roll in degrees at ``fps`` (trimmed, or padded with the last frame, to
    ``n`` frames), the recording's mean pose removed."""
    m = motion.resample(fps)
    pyr = np.degrees(rotvec_to_pitch_yaw_roll(np.asarray(m.rotvec)))
    if len(pyr) >= n:
        pyr = pyr[:n]
    else:
        pyr = np.concatenate([pyr, np.repeat(pyr[-1:], n - len(pyr), axis=0)])
    return pyr - pyr.mean(axis=0)


__all__ = ["centred_degrees"]
