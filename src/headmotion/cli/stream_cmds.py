"""``headmotion stream``: raw 16-bit little-endian mono PCM on stdin → one JSON object per motion
frame on stdout, with any causal model (docs/design.md "CLI").

It calls only the system contract (``model.stream(seed=, gain=, offset=)``, ``model.sample_rate``,
the ``causal`` capability).  Input at another rate than the model's is resampled with one
``soxr.ResampleStream`` kept for the whole session (a one-shot resampler per chunk would restart
its filter at every chunk boundary).  Library considered: python-soxr (the project's resampler).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from ..errors import ParameterError
from .app import app, err_console
from .synth_cmds import load_cli_model, parse_triple


class PcmResampler:
    """Streaming resampling of float32 chunks from ``in_rate`` to ``out_rate`` (identity when equal)."""

    def __init__(self, in_rate: int, out_rate: int):
        self.in_rate, self.out_rate = int(in_rate), int(out_rate)
        self._rs = None
        if self.in_rate != self.out_rate:
            import soxr

            self._rs = soxr.ResampleStream(self.in_rate, self.out_rate, 1, dtype="float32", quality="HQ")

    def __call__(self, x: np.ndarray, *, last: bool = False) -> np.ndarray:
        x = np.asarray(x, dtype=np.float32)
        if self._rs is None:
            return x
        return np.asarray(self._rs.resample_chunk(x, last=last), dtype=np.float32)


def frame_json(index: int, fps: float, rotvec: np.ndarray, pyr_deg: np.ndarray) -> str:
    """One output line: frame index, time, rotation vector and pitch/yaw/roll in degrees."""
    return json.dumps({"frame": index, "time": round(index / fps, 4),
                       "rotvec": [round(float(v), 6) for v in rotvec],
                       "pitch_yaw_roll_deg": [round(float(v), 4) for v in pyr_deg]})


@app.command()
def stream(
    model: Optional[Path] = typer.Option(None, "-m", "--model", help="Model file of a causal system (default: the shipped streaming model, tws-hier)."),
    sample_rate: Optional[int] = typer.Option(None, "--sample-rate", help="Rate of the PCM on stdin (default: the model's)."),
    chunk_ms: float = typer.Option(10.0, "--chunk-ms", help="Read stdin in chunks of this many milliseconds."),
    seed: int = typer.Option(0, "--seed"),
    gain: Optional[str] = typer.Option(None, "--gain", help="G or P,Y,R (see synth --gain)."),
    offset: Optional[str] = typer.Option(None, "--offset", help="Degrees, D or P,Y,R (see synth --offset)."),
):
    """Stream: raw 16-bit PCM (mono, little-endian) on stdin → JSON lines of head rotation on stdout.

    Each line: {"frame": i, "time": s, "rotvec": (rx, ry, rz) as a list, "pitch_yaw_roll_deg": (p, y, r) as a list}."""
    from ..rotations import rotvec_to_pitch_yaw_roll

    if chunk_ms <= 0:
        raise ParameterError(f"--chunk-ms must be positive; got {chunk_ms}")
    if model is None:  # the default model (mfcc-dnn) is not causal: the shipped streaming model
        from .synth_cmds import default_stream_model_path

        model = default_stream_model_path()
    m = load_cli_model(model)
    if not m.causal:
        raise ParameterError(f"system {m.name!r} is not causal and cannot stream")
    st = m.stream(seed=seed, gain=parse_triple(gain, "--gain", default=1.0),
                  offset=parse_triple(offset, "--offset", default=0.0, degrees=True))
    in_sr = int(sample_rate or m.sample_rate)
    resample = PcmResampler(in_sr, m.sample_rate)
    err_console.print(f"streaming with {m.name}: {in_sr} Hz s16le in, JSON lines out; latency ≤ {st.latency_ms:.0f} ms")
    nbytes = max(2, int(round(in_sr * chunk_ms / 1000.0)) * 2)
    out, stdin = sys.stdout, sys.stdin.buffer
    frame = 0

    def emit(motion) -> None:
        nonlocal frame
        if len(motion) == 0:
            return
        pyr = np.degrees(rotvec_to_pitch_yaw_roll(motion.rotvec))
        for rv, a in zip(motion.rotvec, pyr):
            out.write(frame_json(frame, motion.fps, rv, a) + "\n")
            frame += 1
        out.flush()

    leftover = b""
    while True:
        data = stdin.read(nbytes)
        if not data:
            break
        data = leftover + data
        n = len(data) // 2 * 2
        leftover = data[n:]
        emit(st.push(resample(np.frombuffer(data[:n], dtype="<i2").astype(np.float32) / 32768.0)))
    tail = resample(np.zeros(0, dtype=np.float32), last=True)
    if len(tail):
        emit(st.push(tail))
    emit(st.flush())
