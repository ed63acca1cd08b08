"""headmotion: natural head motion from speech.

Give it speech; it returns how the head should nod, turn and tilt (3-DOF rotation over time).
The core types are :class:`Audio`, :class:`Motion` and :class:`FeatureTrack`; the axis
convention is documented in :mod:`headmotion.rotations`.  Synthesis — :func:`synthesize`,
:func:`open_stream`, :func:`load_model`, :func:`list_models`, :class:`Controls` — is
:mod:`headmotion.synthesis`, imported on first use (``import headmotion`` stays light).
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
    "Controls", "load_model", "list_models", "synthesize", "open_stream",
]

#: names served from :mod:`headmotion.synthesis` on first use
_SYNTHESIS = ("Controls", "load_model", "list_models", "synthesize", "open_stream", "DEFAULT_MODEL")


def __getattr__(name: str):
    if name in _SYNTHESIS:
        from . import synthesis

        return getattr(synthesis, name)
    raise AttributeError(f"module 'headmotion' has no attribute {name!r}")
