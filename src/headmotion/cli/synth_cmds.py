"""``headmotion train`` and ``headmotion synth`` (docs/design.md "CLI"); ``stream`` is in
:mod:`.stream_cmds`.

* ``train CORPUS --system NAME -o MODEL.hmz [--speaker S] [--features f0e] [--seed N] [--fps F]`` — fit any
  registered system on a corpus directory (optionally one speaker) with a progress bar; prints one
  summary line: system, recordings, minutes, speakers, seconds taken, file.
* ``synth SPEECH [-m MODEL] -o OUT.{bvh,glb,gltf,csv,json,npz} [--seed N] [--gain G|P,Y,R]
  [--gain-pitch/-yaw/-roll G] [--offset D|P,Y,R] [--offset-pitch/-yaw/-roll D] [--still]
  [--style-from REF] [--neck-share S] [--stochastic S] [--samples K] [--fps F] [--video OUT.mp4]``
  — a thin front end of :func:`headmotion.synthesis.synthesize`, which holds the order of the
  controls and the block-by-block reading of long inputs; ``-m`` takes a shipped name
  (``default``, the default; ``stream``) or a model file (:mod:`headmotion.shipped`);
  ``--samples K --video`` renders the K samples as a labelled grid (:mod:`headmotion.render.samples`).
* ``synth IN... -o DIR [--format F] [--jobs N | --scheduler ADDRESS] [--force]`` — files, folders or
  ``@LIST``, one motion each, resumable (:mod:`.synth_batch`, :mod:`headmotion.batch`).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import typer

from ..errors import ParameterError
from .app import app, console, progress_bar

#: synthesis of at least this much speech (all samples together, seconds) shows a progress bar with
#: the time left, in a terminal
PROGRESS_MIN_SPEECH_S = 60.0


def default_model_path() -> Path:
    """The file of the shipped model ``default``."""
    from ..shipped import shipped_path

    return shipped_path("default")


def default_stream_model_path() -> Path:
    """The file of the shipped model ``stream``, which decides from the speech so far (50 ms behind)."""
    from ..shipped import shipped_path

    return shipped_path("stream")


def load_cli_model(model, default: str = "default"):
    """The model given with ``-m`` (a shipped name or a file), or the shipped ``default``."""
    from ..synthesis import load_model

    return load_model(default if model is None else model)


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
    device: Optional[str] = typer.Option(None, "--device", help="Where the networks train, for systems with a "
                                         "device parameter (motion-flow, the DNN systems): auto (CUDA when torch "
                                         "sees one), cpu or cuda."),
    train_path: Optional[str] = typer.Option(None, "--train-path", help="How the DNN systems read their "
                                             "training data: auto (streamed from disk for a corpus with over "
                                             "an hour of training speech, else in memory), memory or streamed."),
):
    """Train a synthesis system on a corpus and save it."""
    from ..corpus import Corpus
    from ..systems.base import create
    from ..systems.spec import parse_system

    name, set_params = parse_system(system)
    model = create(name, **set_params)
    system = name
    params = model.get_params()
    given = {"features": features, "random_state": seed, "fps": fps, "device": device, "train_path": train_path}
    for k, v in given.items():
        if v is None:
            continue
        if k not in params:
            raise ParameterError(f"--{k.replace('random_state', 'seed').replace('_', '-')} is not a parameter of {system}")
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
    speech: list[Path] = typer.Argument(..., help="Speech audio (wav, flac, mp3, or a video's audio track); "
                                        "several files, folders (searched recursively) or @LIST.txt write one "
                                        "motion each into the folder -o."),
    output: Path = typer.Option(..., "-o", "--output", help="Output motion: .bvh, .glb, .gltf, .csv, .json or .npz "
                                "(a folder for several inputs)."),
    model: Optional[str] = typer.Option(None, "-m", "--model", metavar="NAME|FILE", help="A shipped model by name ('default', the "
                                        "default; 'stream', the causal one; `headmotion models` lists them) "
                                        "or a model file."),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="Synthesis seed: the same seed, the same "
                                        "motion; sample k of --samples uses seed + k (default: the model's own, 0 "
                                        "for the shipped models)."),
    amount: float = typer.Option(1.0, "--amount", help="How much the head moves, 0 to 3: 1 = natural, 2 = "
                                 "animated (larger, faster recorded movements, more of them), 0.5 = calm, 0 = "
                                 "still. Each movement stays a recorded one (motion-matching models)."),
    lookahead_ms: float = typer.Option(0.0, "--lookahead-ms", metavar="MS", help="A live model (-m stream): read "
                                       "the speech this many milliseconds ahead of each frame, 0 to 1080, as "
                                       "`headmotion stream --lookahead-ms` does (default 0: causal)."),
    gain: Optional[str] = typer.Option(None, "--gain", help="Amplitude scale about the model's mean pose: G or "
                                       "P,Y,R (1 = as trained, 0 = held at the mean pose); every angle "
                                       "multiplied (a deeper nod, not a bigger one: see --amount)."),
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
    hear: Optional[Path] = typer.Option(None, "--hear", help="What the head hears: the other party of a conversation "
                                        "(an audio file on the same timeline; either side may be silent). While the "
                                        "other speaks and this head does not, it listens: an attentive posture and "
                                        "recorded nods at the other's back-channel cues."),
    listening: float = typer.Option(1.0, "--listening", help="How much the head listens (with --hear), 0 to 3: "
                                    "0 = it only waits, 1 = posture and nods."),
    fmt: Optional[str] = typer.Option(None, "--format", help="Several inputs: bvh (default), glb, gltf, csv, json "
                                      "or npz."),
    jobs: Optional[int] = typer.Option(None, "--jobs", "-j", help="Several inputs: worker processes (default 1)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Several inputs: Dask scheduler address "
                                            "instead of --jobs, e.g. tcp://host:8786."),
    force: bool = typer.Option(False, "--force", help="Several inputs: make every output again (outputs up to "
                               "date for the same input, model and options are skipped otherwise)."),
):
    """Synthesise head motion for a speech file (the same as headmotion.synthesize in Python).

    Order of the controls: the model's motion (chosen with --amount) → --style-from → --gain/--offset (about the mean pose:
    the reference's when styled, else the model's) → --still replaces everything but the offset →
    --fps."""
    from ..io import load_audio, save_motion
    from ..seeds import model_seed
    from ..synthesis import Controls, reads_in_blocks, synthesize

    if samples < 1:
        raise ParameterError(f"--samples must be >= 1; got {samples}")
    if neck_share is not None and not 0.0 <= neck_share <= 1.0:
        raise ParameterError(f"--neck-share must be between 0 and 1; got {neck_share}")
    controls = Controls.parse(gain=gain, offset_degrees=offset, gain_pyr=(gain_pitch, gain_yaw, gain_roll),
                              offset_pyr_degrees=(offset_pitch, offset_yaw, offset_roll), still=still,
                              amount=amount, style_from=style_from, style_strength=style_strength,
                              style_keep_pose=style_keep_pose, fps=fps, stochastic=stochastic, listening=listening,
                              lookahead_ms=lookahead_ms)
    from .synth_batch import is_batch, run_batch

    if hear is not None and len(speech) != 1:
        raise ParameterError(f"--hear goes with one speech file; got {len(speech)}")

    if is_batch(speech, output, fmt, jobs, scheduler, force):
        code = run_batch(speech, output, model=model, fmt=fmt, jobs=jobs, scheduler=scheduler, force=force,
                         seed=seed, samples=samples, neck_share=neck_share, controls=controls, video=video)
        raise typer.Exit(code)
    speech = speech[0]
    if neck_share is not None and output.suffix.lower() not in (".bvh", ".glb", ".gltf"):
        raise ParameterError(f"--neck-share applies to .bvh, .glb and .gltf outputs; got {output.suffix!r}")
    m = load_cli_model(model)
    t0 = time.perf_counter()
    from ..io.audio_blocks import audio_duration

    with progress_bar(f"synthesising {speech.name}", total=audio_duration(speech) * samples,
                      min_total=PROGRESS_MIN_SPEECH_S) as update:  # a bar for long work, in a terminal
        motions = synthesize(speech, m, seed=seed, samples=samples, controls=controls, hear=hear,
                             progress=lambda done, total: update(done, total=total))
    dt = time.perf_counter() - t0
    save_opts = {} if neck_share is None else {"neck_share": float(neck_share)}
    paths = [output] if samples == 1 else [output.with_name(f"{output.stem}_{k + 1}{output.suffix}")
                                           for k in range(samples)]
    for path, motion in zip(paths, motions):
        save_motion(motion, path, **save_opts)
    for path, motion in zip(paths, motions):
        console.print(f"{path}: {motion}")
    console.print(f"synthesised {motions[0].duration:.1f} s of speech with {m.name} in {dt:.2f} s"
                  + (" (block by block)" if reads_in_blocks(m, speech) else ""))
    if video is not None:
        try:
            from ..render.samples import render_samples
        except ImportError as exc:
            raise ParameterError(f"--video needs headmotion.render, which is not available here ({exc})") from exc
        render_samples(motions, video, audio=load_audio(speech) if hear is None else _mixed(speech, hear),
                       seeds=[model_seed(m, seed) + k for k in range(samples)] if samples > 1 else None,
                       labels=None if samples > 1 else [m.name])
        console.print(f"video → {video}")


def _mixed(speech, hear):
    """Both sides of a conversation in one track (a --video's sound), at the speech's rate."""
    import numpy as np

    from ..io import load_audio
    from ..types import Audio

    a = load_audio(speech)
    b = load_audio(hear, sample_rate=a.sample_rate)
    n = max(len(a.samples), len(b.samples))
    x = np.zeros(n, np.float32)
    x[:len(a.samples)] += a.samples
    x[:len(b.samples)] += b.samples
    return Audio(np.clip(x, -1.0, 1.0), a.sample_rate)
