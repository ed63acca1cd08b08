"""``headmotion train`` and ``headmotion synth`` (docs/design.md "CLI"); ``stream`` is in
:mod:`.stream_cmds`.  Both call only the system contract (:mod:`headmotion.systems.base`).

* ``train CORPUS --system NAME -o MODEL.hmz [--speaker S] [--features f0e] [--seed N] [--fps F]`` — fit any
  registered system on a corpus directory (optionally one speaker) with a progress bar; prints one
  summary line: system, recordings, minutes, speakers, seconds taken, file.
* ``synth SPEECH [-m MODEL] -o OUT.{bvh,glb,gltf,csv,json,npz} [--seed N] [--gain G|P,Y,R]
  [--gain-pitch/-yaw/-roll G] [--offset D|P,Y,R] [--offset-pitch/-yaw/-roll D] [--still]
  [--style-from REF] [--neck-share S] [--stochastic S] [--samples K] [--fps F] [--video OUT.mp4]``
  — without ``-m`` the default model shipped in the package (``headmotion/data/default_model.hmz``)
  is used.  Gain and offset have one meaning (:mod:`headmotion.motion.control`); style is
  :mod:`headmotion.motion.style`; ``--samples K --video`` renders the K samples as a labelled grid
  (:mod:`headmotion.render.samples`).
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
    system: str = typer.Option(..., "--system", "-s", help="System name, e.g. tws-hier, tws-basic, le2012, cccae; "
                               "with parameters as NAME[KEY=VALUE;...], e.g. 'tws-hier[fps=100;idle=0.5]'."),
    output: Path = typer.Option(..., "-o", "--output", help="Model file to write (.hmz)."),
    speaker: Optional[str] = typer.Option(None, "--speaker", help="Train on this speaker only."),
    features: Optional[str] = typer.Option(None, "--features", help="Feature set (f0e, mfcc, lsp, ...)."),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="Random seed for training (the random_state parameter)."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Model frame rate, for systems with an fps parameter "
                                        "(motion is resampled; tws and le2012 default to the corpus rate)."),
):
    """Train a synthesis system on a corpus and save it."""
    from ..corpus import Corpus
    from ..systems.base import create
    from ..systems.spec import parse_system

    name, set_params = parse_system(system)
    model = create(name, **set_params)
    system = name
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


def control_from_options(gain, offset, gain_pyr=(None, None, None), offset_pyr=(None, None, None)):
    """(gain, offset) triples from ``--gain``/``--offset`` and the per-axis ``--gain-pitch`` …
    ``--offset-roll`` options (offsets in degrees on the command line, radians returned)."""
    import math

    from ..motion.control import per_axis

    g = per_axis(parse_triple(gain, "--gain", default=1.0), *gain_pyr, what="gain")
    o_deg = [None if v is None else math.radians(v) for v in offset_pyr]
    o = per_axis(parse_triple(offset, "--offset", default=0.0, degrees=True), *o_deg, what="offset")
    return g, o


@app.command()
def synth(
    speech: Path = typer.Argument(..., help="Speech audio (wav, flac, mp3, or a video's audio track)."),
    output: Path = typer.Option(..., "-o", "--output", help="Output motion: .bvh, .glb, .gltf, .csv, .json or .npz."),
    model: Optional[Path] = typer.Option(None, "-m", "--model", help="Model file (default: the shipped model)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Random seed (stochastic modes, --samples)."),
    gain: Optional[str] = typer.Option(None, "--gain", help="Amplitude scale about the model's mean pose: G or "
                                       "P,Y,R (1 = as trained, 0 = held at the mean pose)."),
    gain_pitch: Optional[float] = typer.Option(None, "--gain-pitch", help="Pitch amplitude scale (overrides --gain)."),
    gain_yaw: Optional[float] = typer.Option(None, "--gain-yaw", help="Yaw amplitude scale (overrides --gain)."),
    gain_roll: Optional[float] = typer.Option(None, "--gain-roll", help="Roll amplitude scale (overrides --gain)."),
    offset: Optional[str] = typer.Option(None, "--offset", help="Added to pitch,yaw,roll after the gain, degrees: "
                                         "D or P,Y,R."),
    offset_pitch: Optional[float] = typer.Option(None, "--offset-pitch", help="Degrees added to pitch (positive: nose down)."),
    offset_yaw: Optional[float] = typer.Option(None, "--offset-yaw", help="Degrees added to yaw (positive: to the speaker's left)."),
    offset_roll: Optional[float] = typer.Option(None, "--offset-roll", help="Degrees added to roll."),
    still: bool = typer.Option(False, "--still", help="A head that does not move: every frame at the rest "
                               "pose (plus any offset), the length and rate of the speech's motion."),
    style_from: Optional[Path] = typer.Option(None, "--style-from", help="Move like this reference: a motion "
                                              "file or a talking video (amplitude, mean pose, slow vs quick motion)."),
    style_strength: float = typer.Option(1.0, "--style-strength", help="0 = the model's style, 1 = the reference's."),
    style_keep_pose: bool = typer.Option(False, "--style-keep-pose", help="Keep the model's mean pose "
                                         "(take only amplitude and spectral balance from the reference)."),
    neck_share: Optional[float] = typer.Option(None, "--neck-share", help="BVH/glTF: share of the rotation on "
                                               "the Neck joint, the rest on Head (default 0.93, measured on "
                                               "real mocap; 0 = all on Head)."),
    samples: int = typer.Option(1, "--samples", help="Number of different samples (OUT_1, OUT_2, ...; with "
                                "--video, one labelled grid)."),
    stochastic: Optional[str] = typer.Option(None, "--stochastic",
                                             help="What to sample: none|choice|params|both (systems with a "
                                                  "stochastic parameter; default the model's)."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Output frame rate (default: the model's)."),
    video: Optional[Path] = typer.Option(None, "--video", help="Also render a preview video (.mp4)."),
):
    """Synthesise head motion for a speech file.

    Order of the controls: the model's motion → --style-from → --gain/--offset (about the mean pose:
    the reference's when styled, else the model's) → --still replaces everything but the offset."""
    from ..io import load_audio, save_motion
    from ..motion.control import apply_gain, mean_pose_of, still as still_motion

    if samples < 1:
        raise ParameterError(f"--samples must be >= 1; got {samples}")
    if neck_share is not None and not 0.0 <= neck_share <= 1.0:
        raise ParameterError(f"--neck-share must be between 0 and 1; got {neck_share}")
    if not 0.0 <= style_strength <= 1.0:
        raise ParameterError(f"--style-strength must be between 0 and 1; got {style_strength}")
    g, o = control_from_options(gain, offset, (gain_pitch, gain_yaw, gain_roll),
                                (offset_pitch, offset_yaw, offset_roll))
    m = load_cli_model(model)
    from ..io.audio_blocks import audio_duration
    from ..systems.long_input import LONG_INPUT_SECONDS, predict_file_in_blocks

    # hours of speech: the model's stream, block by block, in bounded memory (the offline frames)
    long_input = m.can_stream and audio_duration(speech) > LONG_INPUT_SECONDS
    audio = None if long_input else load_audio(speech)

    def predict(seed_k, gain=1.0, offset=0.0):
        if long_input:
            return predict_file_in_blocks(m, speech, seed=seed_k, gain=gain, offset=offset)
        return m.predict(audio, seed=seed_k, gain=gain, offset=offset)

    reference = None
    if style_from is not None:
        from ..motion.style import load_style_reference, style_profile

        reference = style_profile(load_style_reference(style_from))
    if stochastic is None and samples > 1 and m.get_params().get("stochastic") == "none":
        stochastic = "params"  # K samples of a deterministic setting would be K copies
    if stochastic is not None:
        m.set_params(stochastic=stochastic)
    save_opts = {} if neck_share is None else {"neck_share": float(neck_share)}
    if neck_share is not None and output.suffix.lower() not in (".bvh", ".glb", ".gltf"):
        raise ParameterError(f"--neck-share applies to .bvh, .glb and .gltf outputs; got {output.suffix!r}")
    outs = []
    t0 = time.perf_counter()
    for k in range(samples):
        if still:
            motion = still_motion(predict(seed + k), o)
        elif reference is not None:
            from ..motion.style import apply_style

            motion = apply_style(predict(seed + k), reference, strength=style_strength,
                                 match_mean=not style_keep_pose)
            # gain about the styled mean pose (the reference's), or the model's when it is kept
            mean = m.mean_pose_ if style_keep_pose else mean_pose_of([motion.rotvec])
            motion = apply_gain(motion, mean, g, o)
        else:
            motion = predict(seed + k, g, o)
        if fps is not None:
            motion = motion.resample(fps)
        path = output if samples == 1 else output.with_name(f"{output.stem}_{k + 1}{output.suffix}")
        save_motion(motion, path, **save_opts)
        outs.append((path, motion))
    dt = time.perf_counter() - t0
    for path, motion in outs:
        console.print(f"{path}: {motion}")
    console.print(f"synthesised {outs[0][1].duration:.1f} s of speech with {m.name} in {dt:.2f} s"
                  + (" (block by block)" if long_input else ""))
    if video is not None:
        try:
            from ..render.samples import render_samples
        except ImportError as exc:
            raise ParameterError(f"--video needs headmotion.render, which is not available here ({exc})") from exc
        motions = [mo for _, mo in outs]
        if audio is None:
            audio = load_audio(speech)
        render_samples(motions, video, audio=audio,
                       seeds=[seed + k for k in range(samples)] if samples > 1 else None,
                       labels=None if samples > 1 else [m.name])
        console.print(f"video → {video}")
