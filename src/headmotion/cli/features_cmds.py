"""``headmotion features AUDIO --set mfcc [--fps 100] -o OUT.npz``.

Computes one feature set (:mod:`headmotion.features`) of an audio or video file and writes it
atomically: ``.npz`` with ``values`` (T, D) float32, ``fps``, ``names`` and the ``config`` as JSON,
or ``.csv`` with a ``# fps=`` line, a ``time`` column (frame centres, seconds) and one column per
feature — both read back by :func:`headmotion.features.external.load_feature_file`.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import List, Optional

import typer

from ..errors import ParameterError
from .app import app, console
from .key_values import key_values


def _param_value(raw: str):
    """A ``--param`` value: JSON, else ``true``/``false``, else the text."""
    try:
        return json.loads(raw)
    except json.JSONDecodeError:
        return {"true": True, "false": False}.get(raw.strip().lower(), raw)


def write_features(track, path: Path, config: dict | None = None) -> None:
    """Write a FeatureTrack to ``.npz`` or ``.csv`` atomically."""
    import numpy as np

    from ..io.atomic import atomic_open, atomic_path

    ext = path.suffix.lower()
    if ext == ".npz":
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, values=track.values, fps=np.float64(track.fps),
                                    names=np.array(track.names, dtype=str),
                                    config=np.array(json.dumps(config or {})))
    elif ext == ".csv":
        t = np.arange(track.n_frames) / track.fps  # frame t at t / fps (headmotion.align)
        with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
            fh.write(f"# fps={track.fps:g}\n")
            fh.write(",".join(["time", *track.names]) + "\n")
            for ti, row in zip(t, track.values):
                fh.write(f"{ti:.6f}," + ",".join(f"{v:.7g}" for v in row) + "\n")
    else:
        raise ParameterError(f"{path}: cannot write features as {ext or 'a file without extension'!r}; "
                             "expected .npz or .csv")


@app.command("features")
def features(
    audio: Optional[Path] = typer.Argument(None, help="speech audio or a video with an audio track"),
    feature_set: str = typer.Option("mfcc", "--set", "-s", help="feature set (see --list)"),
    fps: float = typer.Option(100.0, "--fps", help="frames per second of the output"),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="OUT.npz or OUT.csv"),
    n_frames: Optional[int] = typer.Option(None, "--frames", help="force this many frames (pad/trim)"),
    param: Optional[List[str]] = typer.Option(None, "--param", "-p",
                                              help="extractor parameter KEY=VALUE (repeatable)"),
    list_sets: bool = typer.Option(False, "--list", help="list the feature sets and exit"),
):
    """Compute speech features (f0e, mfcc, fbank, wav, lsp, lar, prosody) of an audio file."""
    from .. import features as F

    if list_sets:
        for name in F.available():
            console.print(name)
        return
    if audio is None:
        raise ParameterError("give an AUDIO file (or --list)")
    if output is None:
        raise ParameterError("give an output file with -o OUT.npz (or OUT.csv)")
    if output.suffix.lower() not in (".npz", ".csv"):
        raise ParameterError(f"{output}: expected an output ending in .npz or .csv")
    from ..io.audio import load_audio

    params = key_values(param, "--param", _param_value)
    cfg = F.FeatureConfig(feature_set, fps=fps, params=params)
    t0 = time.perf_counter()
    snd = load_audio(audio)
    track = cfg.extract(snd, n_frames=n_frames)
    dt = time.perf_counter() - t0
    write_features(track, output, {"feature": cfg.to_dict(), "audio": str(audio)})
    console.print(
        f"wrote {output}: {track.n_frames}×{track.dim} {feature_set} at {track.fps:g} fps "
        f"({snd.duration:.2f} s of audio, {dt:.2f} s including start-up)",
        highlight=False,
    )
