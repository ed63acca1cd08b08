"""``headmotion train``, ``headmotion synth`` and ``headmotion stream`` (DESIGN.md "CLI").

* ``train CORPUS --system NAME -o MODEL.hmz [--speaker S] [--features f0e] [--seed N] [--fps F]`` — fit any
  registered system on a corpus directory (optionally one speaker) with a progress bar.
* ``synth SPEECH [-m MODEL] -o OUT.{bvh,csv,json,npz} [--seed N] [--gain G] [--samples K]
  [--fps F] [--video OUT.mp4]`` — without ``-m`` the default model shipped in the package
  (``headmotion/data/default_model.hmz``) is used.
* ``stream -m MODEL`` — raw 16-bit little-endian mono PCM on stdin (at the model's sample rate,
  or ``--sample-rate``) → one JSON object per motion frame on stdout.
"""

from __future__ import annotations

import inspect
import json
import sys
import time
from pathlib import Path
from typing import Optional

import typer

from ..errors import ModelFileError, ParameterError
from .app import app, console, err_console, progress_bar


def default_model_path() -> Path:
    """The model file shipped inside the package."""
    return Path(__file__).resolve().parents[1] / "data" / "default_model.hmz"


def _load_model(model: Optional[Path]):
    from ..systems.base import load_model

    path = Path(model) if model is not None else default_model_path()
    if model is None and not path.exists():
        raise ModelFileError(f"{path}: the default model is missing from this installation; give one with -m MODEL.hmz")
    return load_model(path)


def _init_kwargs(cls, **candidates) -> dict:
    """Keep only the keyword arguments ``cls.__init__`` accepts (None values dropped)."""
    params = inspect.signature(cls.__init__).parameters
    return {k: v for k, v in candidates.items() if v is not None and k in params}


@app.command()
def train(
    corpus: Path = typer.Argument(..., help="Corpus directory (with corpus.csv)."),
    system: str = typer.Option(..., "--system", "-s", help="System name, e.g. tws-hier, tws-basic, le2012, cccae."),
    output: Path = typer.Option(..., "-o", "--output", help="Model file to write (.hmz)."),
    speaker: Optional[str] = typer.Option(None, "--speaker", help="Train on this speaker only."),
    features: Optional[str] = typer.Option(None, "--features", help="Feature set (f0e, mfcc, lsp, ...)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Random seed for training."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Model frame rate (motion is resampled; "
                                        "tws systems default to the corpus rate)."),
):
    """Train a synthesis system on a corpus and save it."""
    from ..corpus import Corpus
    from ..systems.base import ANCHORS, system_class

    if system in ANCHORS:
        raise ParameterError(f"{system!r} is an evaluation anchor, not a trainable system")
    cls = system_class(system)
    c = Corpus.load(corpus)
    if speaker is not None:
        c = c.filter(speaker=speaker)
    model = cls(**_init_kwargs(cls, features=features, seed=seed, random_state=seed, fps=fps))
    t0 = time.perf_counter()
    with progress_bar(f"training {system}") as update:
        def progress(done, total, description=None):
            update(done, total=total, description=f"{system}: {description}" if description else None)

        model.fit(c, progress=progress)
    out = model.save(output)
    summ = c.summary()
    console.print(f"trained {system} on {summ['recordings']} recordings ({summ['minutes']:.1f} min, "
                  f"speakers {', '.join(summ['speakers'])}) in {time.perf_counter() - t0:.1f} s → {out}")


def _predict(model, audio, *, seed, gain):
    kw = {}
    params = inspect.signature(model.predict).parameters
    if "gain" in params:
        kw["gain"] = gain
    motion = model.predict(audio, seed=seed, **kw)
    if gain is not None and "gain" not in params and gain != 1.0:
        import numpy as np

        m = motion.rotvec.mean(axis=0)
        motion = motion.replace(rotvec=m + float(gain) * (motion.rotvec - m))
    return motion


@app.command()
def synth(
    speech: Path = typer.Argument(..., help="Speech audio (wav, flac, mp3, or a video's audio track)."),
    output: Path = typer.Option(..., "-o", "--output", help="Output motion: .bvh, .csv, .json or .npz."),
    model: Optional[Path] = typer.Option(None, "-m", "--model", help="Model file (default: the shipped model)."),
    seed: int = typer.Option(0, "--seed", help="Random seed (stochastic modes, --samples)."),
    gain: Optional[float] = typer.Option(None, "--gain", help="Amplitude scale (1 = as trained, 0 = still)."),
    samples: int = typer.Option(1, "--samples", help="Number of different samples (OUT_1, OUT_2, ...)."),
    stochastic: Optional[str] = typer.Option(None, "--stochastic",
                                             help="What to sample (tws: none|cluster|class|params|both); "
                                                  "default 'both' when --samples > 1."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Output frame rate (default: the model's)."),
    video: Optional[Path] = typer.Option(None, "--video", help="Also render a preview video (.mp4)."),
):
    """Synthesise head motion for a speech file."""
    from ..io import load_audio, save_motion

    if samples < 1:
        raise ParameterError(f"--samples must be >= 1; got {samples}")
    m = _load_model(model)
    sr = getattr(m, "sample_rate_", None)
    audio = load_audio(speech, sample_rate=sr)
    if samples > 1 and stochastic is None and hasattr(m, "stochastic"):
        stochastic = "both"
    if stochastic is not None:
        if not hasattr(m, "stochastic"):
            raise ParameterError(f"--stochastic is not available for system {m.name!r}")
        if stochastic == "class" and m.name == "tws-hier":
            stochastic = "cluster"
        if stochastic == "cluster" and m.name == "tws-basic":
            stochastic = "class"
        allowed = ("none", "class", "params", "both") if m.name == "tws-basic" else ("none", "cluster", "params", "both")
        if stochastic not in allowed:
            raise ParameterError(f"--stochastic must be one of {allowed} for {m.name}; got {stochastic!r}")
        m.stochastic = stochastic
    outs = []
    t0 = time.perf_counter()
    for k in range(samples):
        motion = _predict(m, audio, seed=seed + k, gain=gain)
        if fps is not None:
            motion = motion.resample(fps)
        path = output if samples == 1 else output.with_name(f"{output.stem}_{k + 1}{output.suffix}")
        save_motion(motion, path)
        outs.append((path, motion))
    dt = time.perf_counter() - t0
    for path, motion in outs:
        console.print(f"{path}: {motion}")
    console.print(f"synthesised {audio.duration:.1f} s of speech with {m.name} in {dt:.2f} s")
    if video is not None:
        try:
            from ..render import render_video
        except ImportError as exc:
            raise ParameterError(f"--video needs headmotion.render, which is not available here ({exc})") from exc
        # a preview plays at a video rate: motion above 60 fps (e.g. 100) is resampled to 25 fps
        motion_fps = float(outs[0][1].fps)
        render_video(outs[0][1], video, audio=audio, fps=motion_fps if motion_fps <= 60 else 25.0)
        console.print(f"video → {video}")


@app.command()
def stream(
    model: Optional[Path] = typer.Option(None, "-m", "--model", help="Model file of a causal system (default: the shipped model)."),
    sample_rate: Optional[int] = typer.Option(None, "--sample-rate", help="Rate of the PCM on stdin (default: the model's)."),
    chunk_ms: float = typer.Option(10.0, "--chunk-ms", help="Read stdin in chunks of this many milliseconds."),
    seed: int = typer.Option(0, "--seed"),
    gain: Optional[float] = typer.Option(None, "--gain"),
):
    """Stream: raw 16-bit PCM (mono, little-endian) on stdin → JSON lines of head rotation on stdout.

    Each line: {"frame": i, "time": s, "rotvec": (rx, ry, rz) as a list, "pitch_yaw_roll_deg": (p, y, r) as a list}."""
    import numpy as np

    from ..io.audio import resample
    from ..rotations import rotvec_to_pitch_yaw_roll

    m = _load_model(model)
    if not getattr(m, "causal", False):
        raise ParameterError(f"system {m.name!r} is not causal and cannot stream")
    model_sr = int(getattr(m, "sample_rate_", 16000))
    in_sr = int(sample_rate or model_sr)
    kw = {"seed": seed}
    if "gain" in inspect.signature(m.stream).parameters:
        kw["gain"] = gain
    st = m.stream(**kw)
    err_console.print(f"streaming with {m.name}: {in_sr} Hz s16le in, JSON lines out; latency ≤ {st.latency_ms:.0f} ms")
    nbytes = max(2, int(round(in_sr * chunk_ms / 1000.0)) * 2)
    frame = 0
    out = sys.stdout
    stdin = sys.stdin.buffer
    leftover = b""

    def emit(motion):
        nonlocal frame
        if len(motion) == 0:
            return
        pyr = np.degrees(rotvec_to_pitch_yaw_roll(motion.rotvec))
        for rv, a in zip(motion.rotvec, pyr):
            out.write(json.dumps({"frame": frame, "time": round(frame / motion.fps, 4),
                                  "rotvec": [round(float(v), 6) for v in rv],
                                  "pitch_yaw_roll_deg": [round(float(v), 4) for v in a]}) + "\n")
            frame += 1
        out.flush()

    while True:
        data = stdin.read(nbytes)
        if not data:
            break
        data = leftover + data
        n = len(data) // 2 * 2
        leftover = data[n:]
        x = np.frombuffer(data[:n], dtype="<i2").astype(np.float32) / 32768.0
        if in_sr != model_sr:
            x = resample(x, in_sr, model_sr)
        emit(st.push(x))
    emit(st.flush())
