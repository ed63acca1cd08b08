"""Speech in, the robot's head out: the live core's frames placed on a :class:`~.head.ReachyHead`'s
timeline at the wall time their audio plays.

* :func:`speak` — recorded speech, played through a :class:`~.audio.Playback`: the live core reads
  the speech ahead of what has gone to the playback by its latency (lookahead included), a frame
  for the interpolation and 20 ms, so each frame is on the timeline before its audio plays; the
  frame ``n`` goes at ``start + n / fps``, ``start`` being when the first sample plays.  At the
  end the core's settling follows the audio.
* :func:`follow` — live speech (the microphone): frame ``n`` at ``t0 + n / fps + delay``, ``t0``
  the capture time of the first sample and ``delay`` the same margin (100 ms with the shipped
  ``stream`` on 16 kHz audio, 140 ms resampled from another rate): the head trails a live voice by
  that much.
* :func:`listen` — the other party's audio, once the speech is over: the core's listening turn
  (:meth:`~headmotion.live.core.HeadMotionCore.hear`), placed as :func:`follow` places speech.

Each returns when its last frame has been shown, or raises what stopped the commands; a set
``stop`` event (or Ctrl-C in the caller) cuts the speech off: the audio queued is dropped and the
head settles from where it is (:meth:`~.head.ReachyHead.settle`).
"""

from __future__ import annotations

import threading
import time

import numpy as np

from ...live.core import FrameBatch

#: seconds of audio kept queued at the playback ahead of what plays
BUFFER_S = 0.1


def _margin(core, rate: int) -> float:
    """How long after a sample arrives the frame after its own is made, with room to spare: the
    core's latency (lookahead included), the resampler's (when ``rate`` is not the model's), a
    frame (the command rate interpolates up to the next one) and 20 ms."""
    resampling = 0.04 if int(rate) != core.sample_rate else 0.0
    return core.latency_ms / 1000.0 + resampling + 1.0 / core.fps + 0.02


def _place(head, items, anchor: float, fps: float) -> int:
    """Put the frame batches among ``items`` on the head's timeline; returns the frames placed."""
    from ...rotations import rotvec_to_pitch_yaw_roll

    n = 0
    for b in items:
        if isinstance(b, FrameBatch) and len(b):
            times = anchor + (b.first + np.arange(len(b))) / fps
            head.place(times, rotvec_to_pitch_yaw_roll(b.rotvec, degrees=True))
            n += len(b)
    return n


def _origin(head, t: float) -> None:
    """The audio clock's zero for the head's record (the first that is set)."""
    if head.record is not None and head.record.origin is None:
        head.record.origin = t


def _cut(head, core, playback=None) -> None:
    """Cut the speech off: drop the queued audio and the core's utterance, settle the head from
    where it is."""
    if playback is not None:
        playback.clear()
    core.interrupt()
    head.wait_until(head.settle())


def speak(head, samples, sample_rate: int, core, playback, *, chunk_s: float = 0.02,
          stop: threading.Event | None = None) -> dict:
    """Play ``samples`` (float32 mono) through ``playback`` with the head following (module
    docstring).  Returns ``{"start": wall time of the first sample, "audio_s", "frames"}``."""
    x = np.asarray(samples, dtype=np.float32).reshape(-1)
    rate = int(sample_rate)
    step = max(1, int(round(chunk_s * rate)))
    lead = int(round(_margin(core, rate) * rate))
    fps = core.fps
    made: list = []  # frame batches not yet on the timeline
    start = None
    frames = pushed = given = 0
    try:
        while given < len(x):
            if stop is not None and stop.is_set():
                _cut(head, core, playback)
                break
            head.check()
            while pushed < min(len(x), given + lead + step):  # the core reads ahead of the playback
                made.append(core.push(x[pushed:pushed + step], rate))
                pushed += len(x[pushed:pushed + step])
            if playback.queued() > BUFFER_S:
                time.sleep(min(chunk_s / 2, playback.queued() - BUFFER_S))
                continue
            at = playback.play(x[given:given + step])
            if start is None:
                start = at - given / rate
                _origin(head, start)
            given += len(x[given:given + step])
            frames += _place(head, made, start, fps)
            made = []
        else:
            if start is None:  # no audio at all
                return {"start": None, "audio_s": 0.0, "frames": 0}
            frames += _place(head, core.end(), start, fps)  # the tail the lookahead held, the settling
            head.wait_until(max(head.timeline.end, playback.playhead) + 2.0 / head.rate_hz)
    except KeyboardInterrupt:
        _cut(head, core, playback)
        raise
    return {"start": start, "audio_s": len(x) / rate, "frames": frames}


def follow(head, source, core, *, stop: threading.Event | None = None) -> dict:
    """Live speech from ``source`` (a paced :class:`~headmotion.live.inputs.AudioSource`: the
    microphone) until it ends or ``stop``; then the core's settling.  Returns ``{"t0", "frames"}``."""
    delay = _margin(core, source.chunk_rate)
    frames = 0
    try:
        for chunk in source:
            head.check()
            batch = core.push(chunk, source.chunk_rate)
            _origin(head, source.t0)
            frames += _place(head, [batch], source.t0 + delay, core.fps)
            if stop is not None and stop.is_set():
                break
        if source.t0 is not None:
            frames += _place(head, core.end(), source.t0 + delay, core.fps)
            head.wait_until(head.timeline.end + 2.0 / head.rate_hz)
    except KeyboardInterrupt:
        source.close()
        _cut(head, core)
        raise
    return {"t0": source.t0, "frames": frames}


def listen(head, source, core, *, stop: threading.Event | None = None) -> dict:
    """The other party's audio from ``source`` (paced) after the speech: the head listens until it
    ends or ``stop``, then settles to rest.  Returns ``{"frames"}``."""
    delay = _margin(core, source.chunk_rate)
    frames = 0
    try:
        for chunk in source:
            head.check()
            batch = core.hear(chunk, source.chunk_rate)
            frames += _place(head, [batch], source.t0 + delay, core.fps)
            if stop is not None and stop.is_set():
                break
    except KeyboardInterrupt:
        source.close()
        core.end_listening()
        head.wait_until(head.settle())
        raise
    core.end_listening()
    head.wait_until(head.settle())
    return {"frames": frames}


__all__ = ["speak", "follow", "listen", "BUFFER_S"]
