"""``headmotion render``, ``headmotion view`` and ``headmotion plot`` (thesis §4.2.3).

* ``render MOTION... [--audio A] -o OUT.mp4`` — preview video (one motion, or a labelled grid).
* ``view MOTION... [--audio A]`` — serves the browser viewer (three.js) on a local port;
  ``view --live [-m MODEL]`` the live page (microphone or audio file → WebSocket → head).
* ``plot MOTION... -o FIG.png [--audio A]`` — pitch/yaw/roll over time in degrees.

Thin wrappers over :mod:`headmotion.render` and :mod:`headmotion.web`; moderngl, matplotlib and
uvicorn are imported only inside the commands so ``headmotion --help`` stays fast.
"""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from ..errors import ParameterError
from .app import app, console, err_console, progress_bar


def _labels(labels: Optional[str], motions: List[Path]) -> list[str]:
    if labels is None:
        return [p.stem for p in motions]
    out = [s.strip() for s in labels.split(",")]
    if len(out) != len(motions):
        raise ParameterError(f"--labels names {len(out)} motions but {len(motions)} were given: {labels!r}")
    return out


def _load(paths: List[Path]):
    from ..io import load_motion

    return [load_motion(p) for p in paths]


def _load_audio(path: Optional[Path]):
    if path is None:
        return None
    from ..io import load_audio

    return load_audio(path)


@app.command("render")
def render(
    motions: List[Path] = typer.Argument(..., help="motion file(s); several are drawn side by side"),
    out: Path = typer.Option(..., "-o", "--out", help="output video (.mp4)"),
    audio: Optional[Path] = typer.Option(None, "--audio", "-a", help="speech to mux into the video"),
    style: str = typer.Option("textured", "--style", help="textured | smooth | silhouette (thesis §4.2.3)"),
    size: str = typer.Option("640x480", "--size", help="WIDTHxHEIGHT of one head (even numbers)"),
    no_mask: bool = typer.Option(False, "--no-mask", help="no black boxes over the eyes and mouth"),
    labels: Optional[str] = typer.Option(None, "--labels", help="comma-separated labels, one per motion "
                                         "(default: file names; only drawn for several motions)"),
    fps: Optional[float] = typer.Option(None, "--fps", help="video frame rate (default: the motion's)"),
    antialias: bool = typer.Option(False, "--antialias", help="4× multisampling (smoother, ~3× slower)"),
    crf: int = typer.Option(20, "--crf", help="x264 quality (lower is better)"),
    no_translation: bool = typer.Option(False, "--no-translation", help="rotation only, even if the motion has translation"),
):
    """Render head motion as an H.264 video with the speech, one head or a labelled grid."""
    from ..render import render_video

    ms = _load(motions)
    labs = _labels(labels, motions) if (labels is not None or len(motions) > 1) else None
    with progress_bar("rendering", total=None) as update:
        info = render_video(ms, out, audio=audio, style=style, size=size, labels=labs,
                            mask=not no_mask, fps=fps, samples=4 if antialias else 0, crf=crf,
                            translation=not no_translation,
                            progress=lambda d, t: update(d, total=t))
    w, h = info["size"]
    console.print(f"wrote {out} ({info['frames']} frames at {info['fps']:g} fps, {w}x{h}, "
                  f"{info['render_fps']:.0f} frames/s)")


@app.command("view")
def view(
    motions: Optional[List[Path]] = typer.Argument(None, help="motion file(s) to show side by side (not with --live)"),
    audio: Optional[Path] = typer.Option(None, "--audio", "-a", help="speech played in sync"),
    labels: Optional[str] = typer.Option(None, "--labels", help="comma-separated labels, one per motion"),
    port: int = typer.Option(8765, "--port", help="port (0 = any free port)"),
    host: str = typer.Option("127.0.0.1", "--host", help="interface to listen on"),
    no_mask: bool = typer.Option(False, "--no-mask", help="no black boxes over the eyes and mouth"),
    open_browser: bool = typer.Option(True, "--open/--no-open", help="open the page in a web browser"),
    live: bool = typer.Option(False, "--live", help="live page: the microphone or an audio file in the browser "
                              "drives the model through a WebSocket, the head moves as you speak"),
    model: Optional[str] = typer.Option(None, "-m", "--model", metavar="NAME|FILE", help="--live: a model that streams, by shipped "
                                        "name or file (default: the shipped 'stream')"),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="--live: synthesis seed of the stream (default: the model's own)"),
):
    """Serve a local page that plays the speech and animates the head(s) in sync (or, with --live,
    moves the head from the microphone or an audio file as it plays)."""
    if live:
        if motions:
            raise ParameterError("view --live takes no motion files (it makes the motion from the audio); "
                                 f"got {', '.join(map(str, motions))}")
        from ..web.live import serve_live
        from .synth_cmds import load_cli_model

        m = load_cli_model(model, default="stream")  # the low-latency shipped model
        serve_live(m, host=host, port=port, seed=seed, model_path=model or "stream", open_browser=open_browser,
                   announce=lambda url: err_console.print(f"live page at {url}  (Ctrl-C to stop)"))
        return
    if not motions:
        raise ParameterError("view needs motion file(s), or --live for the live page")
    from ..web.server import serve

    ms = _load(motions)
    labs = _labels(labels, motions)
    serve(ms, labels=labs, audio=audio, host=host, port=port, mask=not no_mask,
          open_browser=open_browser, announce=lambda url: err_console.print(f"viewer at {url}  (Ctrl-C to stop)"))


@app.command("plot")
def plot(
    motions: List[Path] = typer.Argument(..., help="motion file(s), overlaid"),
    out: Path = typer.Option(..., "-o", "--out", help="figure (.png, .pdf, .svg)"),
    audio: Optional[Path] = typer.Option(None, "--audio", "-a", help="speech: waveform and F0 underneath"),
    labels: Optional[str] = typer.Option(None, "--labels", help="comma-separated legend labels"),
    no_f0: bool = typer.Option(False, "--no-f0", help="waveform only, no F0 contour"),
    title: Optional[str] = typer.Option(None, "--title"),
):
    """Plot pitch, yaw and roll (degrees) over time; several motions overlaid."""
    from ..render.plot import plot_motion

    ms = _load(motions)
    plot_motion(ms, out, labels=_labels(labels, motions), audio=_load_audio(audio), f0=not no_f0,
                title=title)
    console.print(f"wrote {out}")
