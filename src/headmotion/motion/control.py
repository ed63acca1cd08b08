"""Gain and offset of synthesised motion: the one meaning every system and stream shares.

The seeds are silent on a user-facing amplitude control; the thesis scales template amplitudes
and the paper has none.  Chosen: in pitch / yaw / roll angles (radians, the
convention of :func:`headmotion.rotations.rotvec_to_pitch_yaw_roll`)::

    angles_out = mean_pose + gain * (angles - mean_pose) + offset

``mean_pose`` is the *training data's* mean pose (pitch, yaw, roll), stored in every fitted model
as ``mean_pose_``.  So each angle's standard deviation is multiplied by ``|gain|`` exactly, the
clip mean moves by ``offset`` exactly (for ``gain = 1``), and ``gain = 0`` gives a still head at
the training mean pose plus ``offset``.  ``gain`` and ``offset`` are each a scalar or a
per-axis ``(pitch, yaw, roll)`` triple.  Front ends parse them once into
:class:`headmotion.synthesis.Controls`, which applies them in its order of the controls (about the
styled mean pose when a style reference is given).

Library considered: scipy's Rotation (used underneath by :mod:`headmotion.rotations`); the
scaling itself is one line of numpy.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..rotations import pitch_yaw_roll_to_rotvec, rotvec_to_pitch_yaw_roll
from ..types import Motion


#: the range of ``amount`` (how much the head moves, by the choice of recorded movements; a model
#: that chooses them applies it: :class:`headmotion.systems.motion_match.MotionMatch`)
AMOUNT_RANGE = (0.0, 3.0)


def as_triple(value, what: str) -> np.ndarray:
    """A scalar or a ``(pitch, yaw, roll)`` triple as a finite float array of shape (3,)."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be a number or a (pitch, yaw, roll) triple; got {value!r}") from None
    if a.ndim == 0:
        a = np.full(3, float(a))
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ParameterError(f"{what} must be a finite number or a (pitch, yaw, roll) triple; got {value!r}")
    return a


def is_identity(gain, offset) -> bool:
    """True when ``gain`` is 1 and ``offset`` 0 on every axis (the motion is returned unchanged)."""
    return bool(np.all(as_triple(gain, "gain") == 1.0) and np.all(as_triple(offset, "offset") == 0.0))


def apply_gain_angles(pyr: np.ndarray, mean_pose, gain=1.0, offset=0.0) -> np.ndarray:
    """The module's formula on pitch / yaw / roll angles ``(T, 3)`` in radians."""
    g, o = as_triple(gain, "gain"), as_triple(offset, "offset")
    m = as_triple(mean_pose, "mean_pose")
    return m + g * (np.asarray(pyr, dtype=np.float64) - m) + o


def apply_gain(motion: Motion, mean_pose, gain=1.0, offset=0.0) -> Motion:
    """``motion`` scaled by ``gain`` about ``mean_pose`` and shifted by ``offset`` (radians).

    Returns ``motion`` itself when gain is 1 and offset 0 (bit-identical output)."""
    if is_identity(gain, offset):
        return motion
    if len(motion) == 0:
        return motion
    pyr = apply_gain_angles(rotvec_to_pitch_yaw_roll(motion.rotvec), mean_pose, gain, offset)
    return motion.replace(rotvec=pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]))


def still(motion: Motion, offset=0.0) -> Motion:
    """A motion of ``motion``'s length and rate that does not move: every frame is the rest pose
    (zero rotation) plus ``offset`` (pitch, yaw, roll in radians).  ``--still`` on the command
    line; unlike ``gain=0`` (the training mean pose), the head faces straight ahead."""
    o = as_triple(offset, "offset")
    rv = pitch_yaw_roll_to_rotvec(np.full(len(motion), o[0]), np.full(len(motion), o[1]),
                                  np.full(len(motion), o[2]))
    return motion.replace(rotvec=np.asarray(rv, dtype=np.float64).reshape(len(motion), 3))


def mean_pose_of(rotvecs) -> np.ndarray:
    """The mean (pitch, yaw, roll) in radians over a list of rotation-vector arrays ``(T, 3)``."""
    arrs = [np.asarray(r, dtype=np.float64).reshape(-1, 3) for r in rotvecs]
    arrs = [a for a in arrs if len(a)]
    if not arrs:
        return np.zeros(3)
    return rotvec_to_pitch_yaw_roll(np.vstack(arrs)).mean(axis=0)


__all__ = ["apply_gain", "apply_gain_angles", "as_triple", "is_identity", "mean_pose_of", "still"]
