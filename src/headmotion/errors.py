"""The one exception hierarchy of headmotion.

Every error the package raises on bad input is a :class:`HeadMotionError`; the CLI turns these into
one clear line and a non-zero exit code.  Messages name the file, the offending value and what was
expected (docs/design.md "Style", after librosa's ``util/exceptions.py`` and lhotse's ``DurationMismatchError``).
"""

from __future__ import annotations

from pathlib import Path


class HeadMotionError(Exception):
    """Base class of every error headmotion raises on purpose."""

    exit_code = 1


class ParameterError(HeadMotionError, ValueError):
    """A parameter has a value outside what the function accepts."""

    exit_code = 2


class AudioLoadingError(HeadMotionError):
    """An audio file is missing, empty, truncated, corrupt or not audio at all."""

    exit_code = 3


class SampleRateError(HeadMotionError):
    """Audio has a sample rate the operation cannot use."""

    exit_code = 3


class LengthMismatchError(HeadMotionError):
    """Two time-aligned tracks differ in length by more than the tolerance."""

    exit_code = 4


class FormatError(HeadMotionError):
    """A file does not follow its format.  Carries the file and, where known, the line."""

    exit_code = 5

    def __init__(self, message: str, *, path: str | Path | None = None, line: int | None = None):
        self.path = None if path is None else Path(path)
        self.line = line
        where = ""
        if path is not None:
            where = f"{path}"
            if line is not None:
                where += f", line {line}"
            where += ": "
        super().__init__(where + message)


class NoHeadError(FormatError):
    """A motion file holds no head joint, head markers or head rigid body."""


class NotFittedError(HeadMotionError):
    """A model was used before ``fit`` (or loaded from a file)."""

    exit_code = 6


class ModelFileError(HeadMotionError):
    """A model file is damaged, truncated, foreign, or made for another system."""

    exit_code = 7


class MissingDependencyError(HeadMotionError):
    """An optional dependency (an extra such as ``headmotion[video]``) is not installed."""

    exit_code = 8


class AudioDeviceError(HeadMotionError):
    """No audio input device, no PortAudio library, or a device that cannot be opened."""

    exit_code = 9


class NetworkError(HeadMotionError):
    """A live output cannot listen or send: port in use, bad HOST:PORT, unreachable host."""

    exit_code = 10


__all__ = [
    "HeadMotionError",
    "ParameterError",
    "AudioLoadingError",
    "SampleRateError",
    "LengthMismatchError",
    "FormatError",
    "NoHeadError",
    "NotFittedError",
    "ModelFileError",
    "MissingDependencyError",
    "AudioDeviceError",
    "NetworkError",
]
