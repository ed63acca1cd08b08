"""``headmotion stream``: speech in as it comes (raw PCM on stdin or a named pipe, an audio file
paced in real time, or the microphone) and, with ``--hear``, the other party's audio the head
listens to → head rotation out (JSON lines, VMC over OSC, a WebSocket), with any causal model
(docs/design.md "CLI").

It parses its options once into :class:`headmotion.synthesis.Controls` and calls
:func:`headmotion.live.session.stream_live`, which pushes the inputs through the live core that
every live path shares (:class:`headmotion.live.core.HeadMotionCore`: resampling to the model's
rate, the heard audio on the speech's timeline, the settling at the end) and runs the outputs of
:mod:`headmotion.live`.
"""

from __future__ import annotations

import sys
from typing import Optional

import typer

from ..errors import ParameterError
from .app import app
from .synth_cmds import load_cli_model


@app.command()
def stream(
    model: Optional[str] = typer.Option(None, "-m", "--model", metavar="NAME|FILE", help="A model that streams: a shipped name "
                                        "('stream', the default, 40 ms behind the audio; 'default', about 31 s "
                                        "behind: its pitch is read in 30 s blocks) or a model file."),
    input: str = typer.Option("-", "--input", "-i", help="'-' raw 16-bit mono PCM on stdin, 'mic' the microphone, "
                              "a named pipe of raw PCM, or an audio file."),
    hear: Optional[str] = typer.Option(None, "--hear", metavar="SOURCE", help="The other party's audio, which the "
                                       "head listens to (on the same timeline as --input): an audio file, '-' raw "
                                       "PCM on stdin, 'mic', or a named pipe of raw PCM (see synth --hear)."),
    hear_rate: Optional[int] = typer.Option(None, "--hear-rate", help="Rate of --hear's raw PCM (default: "
                                            "--sample-rate's)."),
    listening: float = typer.Option(1.0, "--listening", help="How much the head listens (with --hear), 0 to 3 "
                                    "(see synth --listening)."),
    realtime: bool = typer.Option(False, "--realtime", help="Pace a file at speech speed (demos, latency tests)."),
    device: Optional[str] = typer.Option(None, "--device", help="Microphone: index or part of its name "
                                         "(default: the system's input)."),
    sample_rate: Optional[int] = typer.Option(None, "--sample-rate", help="Rate of the raw PCM (default: the model's)."),
    chunk_ms: float = typer.Option(10.0, "--chunk-ms", help="Read the input in chunks of this many milliseconds."),
    settle: float = typer.Option(0.0, "--settle", metavar="SECONDS", help="When the input ends, ease the head back "
                                 "to rest (plus --offset) over this many seconds, 0 to 5 (default 0: stop where "
                                 "the speech left it)."),
    vmc: Optional[str] = typer.Option(None, "--vmc", help="Also send the VMC protocol (OSC/UDP) to HOST:PORT "
                                      "(VSeeFace, Warudo, VMagicMirror, EVMC4U; default port 39539)."),
    websocket: Optional[str] = typer.Option(None, "--websocket", help="Also serve JSON frames over a WebSocket "
                                            "at HOST:PORT (any number of clients)."),
    no_json: bool = typer.Option(False, "--no-json", help="Do not write JSON lines on stdout."),
    neck_share: Optional[float] = typer.Option(None, "--neck-share", help="VMC: share of the rotation on the Neck "
                                               "bone (default 0.93, as the BVH/glTF writers)."),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="Synthesis seed (default: the model's own)."),
    amount: float = typer.Option(1.0, "--amount", help="How much the head moves, 0 to 3 (see synth --amount)."),
    lookahead_ms: float = typer.Option(0.0, "--lookahead-ms", metavar="MS", help="Let a live model read the speech "
                                       "this many milliseconds ahead, 0 to 1080 (the frames then come that much "
                                       "later: for speech made before it plays, e.g. a voice agent's TTS). "
                                       "Default 0: causal."),
    gain: Optional[str] = typer.Option(None, "--gain", help="G or P,Y,R (see synth --gain)."),
    offset: Optional[str] = typer.Option(None, "--offset", help="Degrees, D or P,Y,R (see synth --offset)."),
    gain_pitch: Optional[float] = typer.Option(None, "--gain-pitch", help="Pitch amplitude scale (overrides --gain)."),
    gain_yaw: Optional[float] = typer.Option(None, "--gain-yaw", help="Yaw amplitude scale (overrides --gain)."),
    gain_roll: Optional[float] = typer.Option(None, "--gain-roll", help="Roll amplitude scale (overrides --gain)."),
    offset_pitch: Optional[float] = typer.Option(None, "--offset-pitch", help="Degrees added to pitch."),
    offset_yaw: Optional[float] = typer.Option(None, "--offset-yaw", help="Degrees added to yaw."),
    offset_roll: Optional[float] = typer.Option(None, "--offset-roll", help="Degrees added to roll."),
):
    """Stream head motion as the speech comes: PCM on stdin, an audio file or the microphone in;
    JSON lines on stdout, VMC over OSC and/or a WebSocket out.

    Each JSON line: {"frame": i, "time": s, "rotvec": (rx, ry, rz) as a list, "pitch_yaw_roll_deg": (p, y, r) as a list}."""
    from ..live.session import stream_live

    if chunk_ms <= 0:
        raise ParameterError(f"--chunk-ms must be positive; got {chunk_ms}")
    if hear_rate is not None and not 1000 <= hear_rate <= 192000:
        raise ParameterError(f"--hear-rate must be between 1000 and 192000 Hz; got {hear_rate}")
    from ..live.core import SETTLE_RANGE_S, check_seconds

    check_seconds(settle, SETTLE_RANGE_S, "--settle")
    if neck_share is not None and not 0.0 <= neck_share <= 1.0:
        raise ParameterError(f"--neck-share must be between 0 and 1; got {neck_share}")
    from ..synthesis import Controls

    controls = Controls.parse(gain=gain, offset_degrees=offset, gain_pyr=(gain_pitch, gain_yaw, gain_roll),
                              offset_pyr_degrees=(offset_pitch, offset_yaw, offset_roll), amount=amount,
                              listening=listening, lookahead_ms=lookahead_ms)
    m = load_cli_model(model, default="stream")  # the shipped default reads ahead: 'stream' decides as it hears
    stats = stream_live(m, input=input, sample_rate=sample_rate, realtime=realtime, device=device, chunk_ms=chunk_ms,
                json_stream=None if no_json else sys.stdout, vmc=vmc, websocket=websocket, neck_share=neck_share,
                seed=seed, controls=controls, hear=hear, hear_rate=hear_rate, settle_s=settle,
                on_message=_say)
    if stats["frames"] == 0 and input != "mic":  # a microphone stopped at once is no error
        _no_frames(input, stats["chunks"], m, sample_rate)


def _say(message: str) -> None:
    """A line of the stream's own on stderr, as it is (no markup: plain print, so that the first
    frame does not wait for rich)."""
    print(message, file=sys.stderr, flush=True)


def _no_frames(input: str, chunks: int, model, sample_rate: int | None) -> None:
    """An input that gave no frame: one line saying why (exit 1)."""
    from ..errors import AudioLoadingError

    rate = sample_rate or int(model.sample_rate)
    where = "stdin" if input == "-" else input
    if chunks == 0 and input == "-":
        raise AudioLoadingError(f"stdin: no audio arrived; expected raw 16-bit mono PCM at {rate} Hz (--sample-rate "
                                "for another rate), e.g. `headmotion stream < speech.s16le`")
    raise AudioLoadingError(f"{where}: the speech is too short for one frame of head motion (the model makes "
                            f"{float(model.frame_rate):g} frames a second)")
