"""One recording's speech and motion files checked before a corpus accepts them.

The rule is :func:`headmotion.align.recording_tolerance_s`, the one the corpus applies when it
loads the recording, so nothing is accepted at import that a later command refuses."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..align import recording_tolerance_s
from ..errors import LengthMismatchError


@dataclass(frozen=True)
class PairCheck:
    """What the check found: both lengths in seconds, the motion's rate, and the seconds that
    loading the recording will cut from the longer track (0 when they agree)."""

    recording: str
    audio_s: float
    motion_s: float
    fps: float

    @property
    def difference_s(self) -> float:
        return abs(self.audio_s - self.motion_s)

    @property
    def trimmed_s(self) -> float:
        """Seconds cut from the longer track (0 within one motion frame)."""
        return self.difference_s if self.difference_s > 1.0 / self.fps else 0.0

    @property
    def longer(self) -> str:
        return "speech" if self.audio_s > self.motion_s else "motion"


def _audio_seconds(path: Path) -> float:
    from ..io import load_audio
    from ..io.audio_blocks import audio_duration

    seconds = audio_duration(path)
    if not math.isfinite(seconds):  # no length in the header (e.g. MP3 data in a .wav): decode it
        seconds = load_audio(path).duration
    return float(seconds)


def check_pair(audio_path, motion_path, *, recording: str | None = None, fps: float | None = None) -> PairCheck:
    """Read both files' lengths and apply the trimming rule.

    Parameters
    ----------
    audio_path, motion_path : path-like
        The recording's speech and motion files (any format :mod:`headmotion.io` reads).
    recording : str, optional
        The recording's name for messages (default: the motion file's stem).
    fps : float, optional
        The motion's frame rate when its file does not state it.

    Returns
    -------
    PairCheck

    Raises
    ------
    LengthMismatchError
        When speech and motion differ by more than the rule allows; the message names both files
        and both lengths.
    FormatError, AudioLoadingError
        When a file cannot be read.
    """
    from ..io import load_motion

    audio_path, motion_path = Path(audio_path), Path(motion_path)
    name = recording or motion_path.stem
    motion = load_motion(motion_path) if fps is None else load_motion(motion_path).replace(fps=float(fps))
    check = PairCheck(name, _audio_seconds(audio_path), float(motion.duration), float(motion.fps))
    allowed = recording_tolerance_s((check.audio_s, check.motion_s)) + 1.0 / check.fps
    if check.difference_s > allowed + 1e-9:
        raise LengthMismatchError(
            f"{name}: speech {audio_path} lasts {check.audio_s:.3f} s and motion {motion_path} "
            f"{check.motion_s:.3f} s; they differ by {check.difference_s:.3f} s, more than the "
            f"{allowed:.3f} s a recording may be trimmed by (at most 1 s and 2 % of the shorter track)")
    return check


__all__ = ["PairCheck", "check_pair"]
