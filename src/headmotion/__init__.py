"""headmotion: natural head motion from speech.

Give it speech; it returns how the head should nod, turn and tilt (3-DOF rotation over time).
The core types are :class:`Audio`, :class:`Motion` and :class:`FeatureTrack`; the axis
convention is documented in :mod:`headmotion.rotations`.
"""

from __future__ import annotations

__version__ = "0.1.0"

from .errors import (  # noqa: E402
    AudioLoadingError,
    FormatError,
    HeadMotionError,
    LengthMismatchError,
    ModelFileError,
    NoHeadError,
    NotFittedError,
    ParameterError,
    SampleRateError,
)
from .types import Audio, FeatureTrack, Motion  # noqa: E402

__all__ = [
    "__version__", "Audio", "Motion", "FeatureTrack",
    "HeadMotionError", "ParameterError", "AudioLoadingError", "SampleRateError", "LengthMismatchError",
    "FormatError", "NoHeadError", "NotFittedError", "ModelFileError",
]
