"""``headmotion robot reachy SPEECH.wav | --input mic``: a Reachy Mini's head follows the speech
(:mod:`headmotion.integrations.reachy`; docs/robots.md).  Thin: parses the options and calls
:func:`headmotion.integrations.reachy.run.run_reachy`."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from .app import app, console

robot_app = typer.Typer(help="Drive a robot's head with the speech (docs/robots.md).", no_args_is_help=True)
app.add_typer(robot_app, name="robot")


@robot_app.command("reachy")
def reachy(
    speech: Optional[Path] = typer.Argument(None, metavar="[SPEECH.wav]", help="The speech the robot says (any "
                                            "audio file); or --input mic."),
    input: Optional[str] = typer.Option(None, "--input", "-i", help="'mic': follow a live voice on the "
                                        "microphone (not played; the head trails it by ~0.1 s)."),
    host: str = typer.Option("localhost", "--host", help="Where the robot's daemon runs."),
    port: int = typer.Option(8000, "--port", min=1, max=65535, help="The daemon's port (its --fastapi-port)."),
    audio: str = typer.Option("auto", "--audio", help="Where the speech plays: 'robot' (its speaker), 'none' "
                              "(elsewhere: the head keeps the speech's time), 'auto' (the robot's when it has one)."),
    audio_latency: float = typer.Option(0.0, "--audio-latency", metavar="SECONDS", min=0.0, max=2.0,
                                        help="The speaker's own delay, if known: the head moves that much later."),
    hear: Optional[str] = typer.Option(None, "--hear", metavar="SOURCE", help="After the speech, listen to the "
                                       "other party: 'mic' or an audio file (until it ends or Ctrl-C)."),
    device: Optional[str] = typer.Option(None, "--device", help="Microphone: index or part of its name."),
    record: Optional[Path] = typer.Option(None, "--record", metavar="POSES.npz", help="Write the poses sent and "
                                          "those the robot reported (time, pitch/yaw/roll degrees)."),
    rate: float = typer.Option(50.0, "--rate", metavar="HZ", min=1.0, max=200.0, help="Commands per second "
                               "(the daemon's control loop runs at 50)."),
    max_speed: float = typer.Option(150.0, "--max-speed", metavar="DEG_S", min=1.0, max=1000.0,
                                    help="Speed limit of the head, degrees per second."),
    settle: float = typer.Option(0.5, "--settle", metavar="SECONDS", help="Ease back to rest over this long at the "
                                 "end, 0 to 5."),
    timeout: float = typer.Option(5.0, "--timeout", metavar="SECONDS", min=0.5, max=60.0,
                                  help="How long to wait for the daemon."),
    model: Optional[str] = typer.Option(None, "-m", "--model", metavar="NAME|FILE", help="A model that streams "
                                        "(default: 'stream')."),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="Synthesis seed (default: the model's own)."),
    amount: float = typer.Option(1.0, "--amount", help="How much the head moves, 0 to 3 (see synth --amount)."),
    gain: Optional[str] = typer.Option(None, "--gain", help="G or P,Y,R (see synth --gain)."),
    offset: Optional[str] = typer.Option(None, "--offset", help="Degrees, D or P,Y,R: also the rest pose."),
):
    r"""A Reachy Mini's head follows the speech: the shipped live model's motion at the robot's
    command rate, within its head range and a speed limit, in time with the audio; it settles to
    rest at the end or on Ctrl-C.

    Needs the robot's SDK (pip install "headmotion\[reachy]") and its daemon running
    (reachy-mini-daemon; without a robot: reachy-mini-daemon --mockup-sim --headless)."""
    from ..errors import ParameterError
    from ..live.core import SETTLE_RANGE_S, check_seconds
    from ..synthesis import Controls

    check_seconds(settle, SETTLE_RANGE_S, "--settle")
    if speech is not None and input is not None:
        raise ParameterError("give SPEECH.wav or --input mic, not both")
    from ..integrations.reachy.motion import HeadLimits
    from ..integrations.reachy.run import run_reachy

    controls = Controls.parse(gain=gain, offset_degrees=offset, amount=amount)
    out = run_reachy(speech, input=input, host=host, port=port, audio=audio, hear=hear, device=device,
                     record=record, model=model or "stream", seed=seed, controls=controls, rate_hz=rate,
                     limits=HeadLimits(speed=max_speed), settle_s=settle, timeout_s=timeout,
                     audio_latency_s=audio_latency)
    where = f"; poses → {record}" if record is not None else ""
    console.print(f"{out['frames']} frames, {out['commands']} commands{where}", highlight=False, soft_wrap=True)
