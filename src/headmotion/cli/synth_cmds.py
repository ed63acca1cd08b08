"""``headmotion train`` and ``headmotion synth`` (docs/design.md "CLI"); ``stream`` is in
:mod:`.stream_cmds`.  Both call only the system contract (:mod:`headmotion.systems.base`).

* ``train CORPUS --system NAME -o MODEL.hmz [--speaker S] [--features f0e] [--seed N] [--fps F]`` — fit any
  registered system on a corpus directory (optionally one speaker) with a progress bar; prints one
  summary line: system, recordings, minutes, speakers, seconds taken, file.
* ``synth SPEECH [-m MODEL] -o OUT.{bvh,csv,json,npz} [--seed N] [--gain G] [--offset P,Y,R]
  [--stochastic S] [--samples K] [--fps F] [--video OUT.mp4]`` — without ``-m`` the default model
  shipped in the package (``headmotion/data/default_model.hmz``) is used.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import typer

from ..errors import ModelFileError, ParameterError
from .app import app, console, progress_bar


def default_model_path() -> Path:
    """The model file shipped inside the package."""
    return Path(__file__).resolve().parents[1] / "data" / "default_model.hmz"


def default_stream_model_path() -> Path:
    """The causal model shipped for ``headmotion stream`` (the default model is not causal)."""
    return Path(__file__).resolve().parents[1] / "data" / "default_stream_model.hmz"


def load_cli_model(model: Optional[Path]):
    """The model file given, or the shipped default."""
    from ..systems.base import load_model

    path = Path(model) if model is not None else default_model_path()
    if model is None and not path.exists():
        raise ModelFileError(f"{path}: the default model is missing from this installation; give one with -m MODEL.hmz")
    return load_model(path)


def parse_triple(text: Optional[str], what: str, *, default: float, degrees: bool = False):
    """``"x"`` or ``"p,y,r"`` from the command line as a float or a 3-tuple (degrees → radians)."""
    import math

    if text is None:
        return default
    try:
        vals = [float(v) for v in str(text).split(",")]
    except ValueError:
        raise ParameterError(f"{what} must be a number or three comma-separated numbers (pitch,yaw,roll); "
                             f"got {text!r}") from None
    if len(vals) not in (1, 3):
        raise ParameterError(f"{what} must be one number or three (pitch,yaw,roll); got {text!r}")
    if degrees:
        vals = [math.radians(v) for v in vals]
    return vals[0] if len(vals) == 1 else tuple(vals)


@app.command()
def train(
    corpus: Path = typer.Argument(..., help="Corpus directory (with corpus.csv)."),
    system: str = typer.Option(..., "--system", "-s", help="System name, e.g. tws-hier, tws-basic, le2012, cccae."),
    output: Path = typer.Option(..., "-o", "--output", help="Model file to write (.hmz)."),
    speaker: Optional[str] = typer.Option(None, "--speaker", help="Train on this speaker only."),
    features: Optional[str] = typer.Option(None, "--features", help="Feature set (f0e, mfcc, lsp, ...)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Random seed for training (the random_state parameter)."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Model frame rate, for systems with an fps parameter "
                                        "(motion is resampled; tws and le2012 default to the corpus rate)."),
):
    """Train a synthesis system on a corpus and save it."""
    from ..corpus import Corpus
    from ..systems.base import create

    model = create(system)
    params = model.get_params()
    given = {"features": features, "random_state": seed, "fps": fps}
    for k, v in given.items():
        if v is None:
            continue
        if k not in params:
            raise ParameterError(f"--{k.replace('random_state', 'seed')} is not a parameter of {system}")
        model.set_params(**{k: v})
    c = Corpus.load(corpus)
    if speaker is not None:
        c = c.filter(speaker=speaker)
    t0 = time.perf_counter()
    with progress_bar(f"training {system}") as update:
        def progress(done, total, description=None):
            update(done, total=total, description=f"{system}: {description}" if description else None)

        model.fit(c, progress=progress)
    out = model.save(output)
    summ = c.summary()
    console.print(f"trained {system}: {summ['recordings']} recordings, {summ['minutes']:.1f} min, "
                  f"speakers {', '.join(summ['speakers'])}, {time.perf_counter() - t0:.1f} s → {out}")


@app.command()
def synth(
    speech: Path = typer.Argument(..., help="Speech audio (wav, flac, mp3, or a video's audio track)."),
    output: Path = typer.Option(..., "-o", "--output", help="Output motion: .bvh, .csv, .json or .npz."),
    model: Optional[Path] = typer.Option(None, "-m", "--model", help="Model file (default: the shipped model)."),
    seed: int = typer.Option(0, "--seed", help="Random seed (stochastic modes, --samples)."),
    gain: Optional[str] = typer.Option(None, "--gain", help="Amplitude scale about the training mean pose: G or "
                                       "P,Y,R (1 = as trained, 0 = still)."),
    offset: Optional[str] = typer.Option(None, "--offset", help="Added to pitch,yaw,roll after the gain, degrees: "
                                         "D or P,Y,R."),
    samples: int = typer.Option(1, "--samples", help="Number of different samples (OUT_1, OUT_2, ...)."),
    stochastic: Optional[str] = typer.Option(None, "--stochastic",
                                             help="What to sample: none|choice|params|both (systems with a "
                                                  "stochastic parameter); default 'both' when --samples > 1."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Output frame rate (default: the model's)."),
    video: Optional[Path] = typer.Option(None, "--video", help="Also render a preview video (.mp4)."),
):
    """Synthesise head motion for a speech file."""
    from ..io import load_audio, save_motion

    if samples < 1:
        raise ParameterError(f"--samples must be >= 1; got {samples}")
    g = parse_triple(gain, "--gain", default=1.0)
    o = parse_triple(offset, "--offset", default=0.0, degrees=True)
    m = load_cli_model(model)
    audio = load_audio(speech)
    if stochastic is None and samples > 1 and "stochastic" in m.get_params():
        stochastic = "both"
    if stochastic is not None:
        m.set_params(stochastic=stochastic)
    outs = []
    t0 = time.perf_counter()
    for k in range(samples):
        motion = m.predict(audio, seed=seed + k, gain=g, offset=o)
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
