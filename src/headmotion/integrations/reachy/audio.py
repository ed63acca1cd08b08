"""Where the robot's speech plays, and the clock the head keeps time by.

:class:`Playback` plays nothing: the speech "plays" in real time from when it is given, one chunk
after another, which is the clock the head follows (the audio is played elsewhere, or not at all).
:class:`RobotSpeaker` also pushes it to the robot's speaker through the SDK's media
(``media.start_playing()``, ``media.push_audio_sample(float32)`` at the output's rate, and
``media.audio.clear_player()`` to drop what is queued when cut off).  ``latency_s`` is the output's
own delay, if known: it moves the clock later.
"""

from __future__ import annotations

import time

import numpy as np


class Playback:
    """Speech played in real time from when it is given (module docstring)."""

    name = "no audio (the head keeps the audio's time)"

    def __init__(self, sample_rate: int, *, latency_s: float = 0.0, clock=time.monotonic):
        self.sample_rate, self.latency_s, self.clock = int(sample_rate), float(latency_s), clock
        self.playhead = -float("inf")

    def play(self, samples) -> float:
        """Queue ``samples`` (float32 mono at ``sample_rate``); returns when their first one plays."""
        start = max(self.clock(), self.playhead)
        self.playhead = start + len(samples) / self.sample_rate
        self._write(np.asarray(samples, dtype=np.float32))
        return start + self.latency_s

    def queued(self) -> float:
        """Seconds of audio given that have not played yet."""
        return max(0.0, self.playhead - self.clock())

    def clear(self) -> None:
        """Drop the audio not played yet (the speech was cut off)."""
        self.playhead = min(self.playhead, self.clock())
        self._drop()

    def _write(self, samples: np.ndarray) -> None:  # noqa: B027 - nothing to play here
        pass

    def _drop(self) -> None:  # noqa: B027
        pass

    def close(self) -> None:  # noqa: B027
        pass


class RobotSpeaker(Playback):
    """The speech on the robot's speaker (the SDK's ``media``, opened with the robot's media)."""

    name = "the robot's speaker"

    def __init__(self, media, sample_rate: int, *, latency_s: float = 0.0, clock=time.monotonic):
        from ...errors import AudioDeviceError
        from ...io.resampler import Resampler

        super().__init__(sample_rate, latency_s=latency_s, clock=clock)
        if getattr(media, "audio", None) is None:
            raise AudioDeviceError("the robot has no audio output (its daemon runs without media, or the SDK "
                                   "could not open it)")
        self.media = media
        out_rate = int(media.get_output_audio_samplerate())
        self._resample = Resampler(self.sample_rate, out_rate, quality="LQ")
        media.start_playing()

    def _write(self, samples: np.ndarray) -> None:
        y = self._resample(samples)
        if len(y):
            self.media.push_audio_sample(np.ascontiguousarray(y, dtype=np.float32))

    def _drop(self) -> None:
        self.media.audio.clear_player()

    def close(self) -> None:
        self.media.stop_playing()


__all__ = ["Playback", "RobotSpeaker"]
