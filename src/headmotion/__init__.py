"""headmotion: natural head motion from speech.

Give it speech; it returns how the head should nod, turn and tilt (3-DOF rotation over time).
The core types are :class:`Audio`, :class:`Motion` and :class:`FeatureTrack`; the axis
convention is documented in :mod:`headmotion.rotations`.

``import headmotion`` loads only the error classes: the types (numpy, scipy's rotations) and
everything else are imported on first use (module ``__getattr__``, PEP 562), so that a command
such as ``headmotion --help`` pays for nothing it does not use.  Synthesis — :func:`synthesize`,
:func:`open_stream`, :func:`load_model`, :func:`list_models`, :class:`Controls` — is
:mod:`headmotion.synthesis`; :func:`adapt` (a model adapted to one speaker) is
:mod:`headmotion.systems.adapt`; :func:`synthesize_batch` (many files to motion files, on this
machine's cores or a Dask cluster) is :mod:`headmotion.batch`.
"""

from __future__ import annotations

import importlib

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

#: names re-exported lazily: name → the module that defines it
_LAZY = {
    "Audio": ".types", "Motion": ".types", "FeatureTrack": ".types",
    **{name: ".synthesis" for name in ("Controls", "load_model", "list_models", "synthesize", "open_stream",
                                       "DEFAULT_MODEL")},
    "adapt": ".systems.adapt",
    "synthesize_batch": ".batch",
}


def __getattr__(name: str):
    """The lazily re-exported names (``headmotion.Motion`` imports :mod:`headmotion.types`)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'headmotion' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "__version__", "Audio", "Motion", "FeatureTrack",
    "HeadMotionError", "ParameterError", "AudioLoadingError", "SampleRateError", "LengthMismatchError",
    "FormatError", "NoHeadError", "NotFittedError", "ModelFileError",
    "Controls", "load_model", "list_models", "synthesize", "open_stream", "adapt", "synthesize_batch",
]
