"""The one exception hierarchy of headmotion.

Every error the package raises on bad input is a :class:`HeadMotionError`; the CLI turns these into
one clear line on stderr and a documented exit code (``headmotion --help`` lists them):

====  =====================================================================================
0     success
1     bad input: a file that is missing, damaged or not what was expected (every error below
      unless listed otherwise)
2     usage: unknown command or option, a missing argument, a value out of range
      (:class:`ParameterError` and click's usage errors)
3     a missing optional dependency (:class:`MissingDependencyError`, e.g. ``headmotion[video]``)
4     internal error (a bug): the message says so and ``--debug`` shows the traceback
130   interrupted (Ctrl-C); no output file is left half-written
====  =====================================================================================

Messages name the file, the offending value and what was expected (docs/design.md "Style", after librosa's ``util/exceptions.py`` and lhotse's ``DurationMismatchError``).
"""

from __future__ import annotations

from pathlib import Path


class HeadMotionError(Exception):
    """Base class of every error headmotion raises on purpose; its ``exit_code`` (1, bad input) is
    every subclass's that does not set its own."""

    exit_code = 1


class ParameterError(HeadMotionError, ValueError):
    """A parameter has a value outside what the function accepts."""

    exit_code = 2


class AudioLoadingError(HeadMotionError):
    """An audio file is missing, empty, truncated, corrupt or not audio at all."""


class SampleRateError(HeadMotionError):
    """Audio has a sample rate the operation cannot use."""


class LengthMismatchError(HeadMotionError):
    """Two time-aligned tracks differ in length by more than the tolerance."""


class FormatError(HeadMotionError):
    """A file does not follow its format.  Carries the file and, where known, the line."""

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


class ModelFileError(HeadMotionError):
    """A model file is damaged, truncated, foreign, or made for another system."""


class MissingDependencyError(HeadMotionError):
    """An optional dependency (an extra such as ``headmotion[video]``) is not installed."""

    exit_code = 3


class AudioDeviceError(HeadMotionError):
    """No audio input device, no PortAudio library, or a device that cannot be opened (exit 1: the
    input asked for is not there)."""


class NetworkError(HeadMotionError):
    """A live output cannot listen or send: port in use, bad HOST:PORT, unreachable host (exit 1)."""


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
