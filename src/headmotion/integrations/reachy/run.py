"""``headmotion robot reachy`` as one call: :func:`run_reachy` connects, plays or follows the
speech, listens after it when asked, settles the head and writes the record."""

from __future__ import annotations

import sys
from collections.abc import Callable

from ...errors import AudioDeviceError, ParameterError


def _stderr(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run_reachy(speech=None, *, input: str | None = None, host: str = "localhost", port: int = 8000,
               audio: str = "auto", hear: str | None = None, record=None, model="stream", seed: int | None = None,
               controls=None, rate_hz: float = 50.0, limits=None, settle_s: float = 0.5, device=None,
               timeout_s: float = 5.0, audio_latency_s: float = 0.0,
               on_message: Callable[[str], None] = _stderr) -> dict:
    """Drive the robot's head with ``speech`` (an audio file, played through ``audio``: ``auto``
    the robot's speaker when it has one, ``robot``, or ``none``) or ``input="mic"`` (a live voice,
    not played); with ``hear`` (an audio file or ``mic``) the head listens to the other party after
    the speech.  ``record``: the ``.npz`` of the commands (written even when the robot went away).
    Returns ``{"frames", "commands", "audio_s"}``."""
    if (speech is None) == (input is None):
        raise ParameterError("give the speech as a file (SPEECH.wav) or --input mic, one of the two")
    if input is not None and input != "mic":
        raise ParameterError(f"--input takes 'mic' (a speech file is given as SPEECH.wav); got {input!r}")
    if audio not in ("auto", "robot", "none"):
        raise ParameterError(f"--audio must be auto, robot or none; got {audio!r}")
    if hear is not None and speech is None:
        raise ParameterError("--hear listens after the speech: it needs a speech file (not --input mic)")
    from ...live.core import HeadMotionCore
    from ...live.hold import agent_core
    from ...live.inputs import open_input
    from ...rotations import rotvec_to_pitch_yaw_roll
    from .audio import Playback, RobotSpeaker
    from .head import ReachyHead
    from .motion import HeadLimits
    from .play import follow, listen, speak

    limits = limits or HeadLimits()
    live = input == "mic"
    if live:
        core = HeadMotionCore(model, seed=seed, controls=controls, settle_s=settle_s, resample="fast")
    else:
        core = agent_core(model, seed=seed, controls=controls, settle_s=settle_s)
    rest = rotvec_to_pitch_yaw_roll(core.rest_pose, degrees=True)[0]
    clip = None
    if speech is not None:
        from ...io import load_audio

        clip = load_audio(speech)
    media = not live and audio != "none"
    try:
        head = ReachyHead(host=host, port=port, rate_hz=rate_hz, limits=limits, rest=rest, record=record is not None,
                          media=media, timeout_s=timeout_s, settle_s=settle_s)
    except AudioDeviceError as exc:
        if audio == "robot":
            raise AudioDeviceError(f"{exc}; play the speech elsewhere with --audio none") from None
        on_message(f"warning: {exc}: the speech is not played, the head keeps its time")
        media = False
        head = ReachyHead(host=host, port=port, rate_hz=rate_hz, limits=limits, rest=rest, record=record is not None,
                          timeout_s=timeout_s, settle_s=settle_s)
    playback = None
    out = {"frames": 0, "commands": 0, "audio_s": 0.0}
    try:
        head.start()
        if clip is not None:
            playback = Playback(clip.sample_rate, latency_s=audio_latency_s)
            if media:
                try:
                    playback = RobotSpeaker(head.robot.media, clip.sample_rate, latency_s=audio_latency_s)
                except AudioDeviceError as exc:
                    if audio == "robot":
                        raise AudioDeviceError(f"{exc}; play the speech elsewhere with --audio none") from None
                    on_message(f"warning: {exc}: the speech is not played, the head keeps its time")
            on_message(f"Reachy Mini at {host}:{port}: {speech} on {playback.name}, {head.rate_hz:g} commands/s")
            res = speak(head, clip.samples, clip.sample_rate, core, playback)
            out.update(frames=res["frames"], audio_s=res["audio_s"])
            if hear is not None:
                source = open_input(hear, realtime=True, device=device, on_message=on_message)
                on_message(f"listening to {source.name}")
                out["frames"] += listen(head, source, core)["frames"]
        else:
            source = open_input("mic", device=device, on_message=on_message)
            on_message(f"Reachy Mini at {host}:{port}: following {source.name} (Ctrl-C to stop)")
            res = follow(head, source, core)
            out["frames"] = res["frames"]
        head.stop()
    finally:
        head.close()
        if playback is not None:
            playback.close()
        if record is not None and head.record is not None:
            head.record.save(record)
        out["commands"] = head.commands
    return out


__all__ = ["run_reachy"]
