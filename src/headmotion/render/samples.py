"""Several samples of the same speech side by side, so a user can pick one.

The thesis's systems are stochastic (§5.4: tws-hier draws templates; every seed gives another
plausible motion), and the listening tests put motions of one sentence side by side (§4.2.3).
:func:`render_samples` draws K motions of one speech as a labelled grid video with the speech —
one cell per sample, labelled with its number and seed — through
:func:`headmotion.render.video.render_video` (which already lays out grids); this module only
chooses the labels, the cell size and a video frame rate.

Libraries: the project's own renderer (moderngl) and imageio-ffmpeg's ffmpeg, as render_video.
"""

from __future__ import annotations

from ..errors import ParameterError
from ..types import Motion

#: Above this motion frame rate the preview is rendered at :data:`PREVIEW_FPS` (as ``synth --video``).
MAX_VIDEO_FPS = 60.0
PREVIEW_FPS = 25.0


def sample_labels(k: int, seeds=None) -> list[str]:
    """``"sample 1 · seed 7"``, … (``"sample 1"``, … without seeds)."""
    if seeds is None:
        return [f"sample {i + 1}" for i in range(k)]
    seeds = list(seeds)
    if len(seeds) != k:
        raise ParameterError(f"{len(seeds)} seeds given for {k} samples")
    return [f"sample {i + 1} · seed {s}" for i, s in enumerate(seeds)]


def render_samples(samples, out, *, audio=None, seeds=None, labels=None, size=None, fps=None,
                   grid=None, **kwargs) -> dict:
    """Render K motions of one speech as a labelled grid MP4 with the speech.

    Parameters
    ----------
    samples : list of Motion (the same speech; they may differ in length — shorter ones hold
        their last pose)
    out : str or Path, the ``.mp4`` (written atomically)
    audio : Audio or path of the speech, or None
    seeds : list of int, optional, shown in the labels (one per sample)
    labels : list of str, optional, overrides the ``sample i · seed s`` labels
    size : (w, h) or "WxH" of one cell; default 640×480 for one sample, 480×360 for two to four,
        320×240 for more (so a 3×3 grid stays under 1000 pixels wide)
    fps : video frame rate; default the motion's, or 25 when the motion runs above 60 fps
    grid : (rows, cols), default one row up to 4 samples, else near-square
    **kwargs : passed to :func:`headmotion.render.video.render_video` (``style``, ``mask``, …)

    Returns
    -------
    render_video's dict (``path``, ``frames``, ``fps``, ``size``, ``seconds``, ``render_fps``)
    """
    from .video import render_video

    ms = [samples] if isinstance(samples, Motion) else list(samples)
    if not ms:
        raise ParameterError("render_samples needs at least one motion")
    for m in ms:
        if not isinstance(m, Motion):
            raise ParameterError(f"render_samples needs Motion objects; got {type(m).__name__}")
    k = len(ms)
    if labels is None:
        labels = sample_labels(k, seeds)
    if size is None:
        size = (640, 480) if k == 1 else (480, 360) if k <= 4 else (320, 240)
    if fps is None:
        fps = ms[0].fps if ms[0].fps <= MAX_VIDEO_FPS else PREVIEW_FPS
    return render_video(ms, out, audio=audio, labels=labels, size=size, fps=fps, grid=grid, **kwargs)


__all__ = ["render_samples", "sample_labels"]
