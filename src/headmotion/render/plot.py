"""Figures of head motion over time: pitch, yaw and roll in degrees, several motions overlaid,
with the speech waveform and its F0 underneath (the kind of figure in thesis ch. 3–5 and the
paper's Fig. 2).

Angles are the intrinsic yaw → pitch → roll decomposition of :meth:`Motion.as_pitch_yaw_roll`
(which for small rotations equals the rotation-vector components).  F0 comes from Praat via
parselmouth (``Sound.to_pitch``, the library the design names for F0); matplotlib draws with the
non-interactive Agg backend.  Libraries considered: plotly (interactive, but researchers put PNG/PDF
in papers), seaborn (nothing to add for line plots).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..types import Audio, Motion

_AXES = ("pitch (+ nose down)", "yaw (+ nose to speaker's left)", "roll (+ top to speaker's right)")


def _load_audio(audio) -> Audio | None:
    if audio is None or isinstance(audio, Audio):
        return audio
    try:
        from ..io import load_audio
    except ImportError:  # audio I/O module not available: read with soundfile directly
        import soundfile as sf

        from ..errors import AudioLoadingError

        try:
            x, sr = sf.read(str(audio), dtype="float32", always_2d=True)
        except Exception as exc:
            raise AudioLoadingError(f"cannot read audio {audio}: {exc}") from exc
        return Audio(x.mean(axis=1), sr)
    return load_audio(audio)


def f0_track(audio: Audio, *, time_step: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """F0 of ``audio`` with Praat's autocorrelation method: times ``(T,)`` s and F0 ``(T,)`` Hz,
    NaN where unvoiced."""
    import parselmouth

    snd = parselmouth.Sound(audio.samples.astype(np.float64), sampling_frequency=audio.sample_rate)
    pitch = snd.to_pitch(time_step=time_step)
    f0 = pitch.selected_array["frequency"].astype(float)
    f0[f0 <= 0] = np.nan
    return pitch.xs(), f0


def plot_motion(motions, out=None, *, labels=None, audio=None, f0: bool = True, title=None,
                figsize=None, dpi: int = 150):
    """Plot pitch, yaw and roll (degrees) over time, optionally with the speech underneath.

    Parameters
    ----------
    motions : Motion or list of Motion, overlaid in each panel
    out : path of the figure (``.png``, ``.pdf``, ``.svg``), or None to only return the figure
    labels : list of str, one per motion (legend), or None
    audio : Audio or audio file path, or None — adds a waveform panel (and F0 if ``f0``)
    f0 : bool, draw the F0 contour (Praat) over the waveform panel
    title : str or None
    figsize : (w, h) inches or None
    dpi : resolution of raster output

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    ms = [motions] if isinstance(motions, Motion) else list(motions)
    if not ms:
        raise ParameterError("plot_motion needs at least one motion")
    if labels is None:
        labels = [m.meta.get("label") or m.meta.get("source") or f"motion {i + 1}" for i, m in enumerate(ms)]
        labels = [Path(str(s)).name if isinstance(s, str) else str(s) for s in labels]
    if len(labels) != len(ms):
        raise ParameterError(f"{len(labels)} labels given for {len(ms)} motions")
    au = _load_audio(audio)
    n_panels = 3 + (au is not None)
    fig = Figure(figsize=figsize or (9, 1.9 * n_panels + 0.6), layout="constrained")
    axes = fig.subplots(n_panels, 1, sharex=True)
    for m, lab in zip(ms, labels):
        deg = m.as_pitch_yaw_roll(degrees=True)
        t = m.times
        for k in range(3):
            axes[k].plot(t, deg[:, k], lw=1.2, label=str(lab))
    for k in range(3):
        axes[k].set_ylabel(f"{_AXES[k].split(' ')[0]} (°)")
        axes[k].set_title(_AXES[k], fontsize=9, loc="left")
        axes[k].axhline(0, color="0.7", lw=0.6, zorder=0)
        axes[k].grid(alpha=0.3)
    if len(ms) > 1 or labels[0]:
        axes[0].legend(loc="upper right", fontsize=8, ncol=min(len(ms), 4), framealpha=0.8)
    if au is not None:
        ax = axes[3]
        x = au.samples
        step = max(1, len(x) // 3000)  # min/max envelope per block: the waveform as drawn in papers
        n = len(x) // step * step
        if step > 1:
            blk = x[:n].reshape(-1, step)
            tt = np.arange(blk.shape[0]) * step / au.sample_rate
            ax.fill_between(tt, blk.min(1), blk.max(1), color="0.6", lw=0.3, edgecolor="0.6")
        else:
            ax.plot(np.arange(len(x)) / au.sample_rate, x, color="0.55", lw=0.5)
        ax.set_ylabel("speech")
        ax.set_yticks([])
        if f0:
            ts, hz = f0_track(au)
            ax2 = ax.twinx()
            ax2.plot(ts, hz, ".", ms=2, color="C3")
            ax2.set_ylabel("F0 (Hz)", color="C3")
            ax2.tick_params(axis="y", colors="C3")
    axes[-1].set_xlabel("time (s)")
    dur = max(m.duration for m in ms)
    if au is not None:
        dur = max(dur, au.duration)
    axes[-1].set_xlim(0, dur)
    if title:
        fig.suptitle(title)
    if out is not None:
        from ..io.atomic import atomic_path

        out = Path(out)
        if out.suffix.lower() not in (".png", ".pdf", ".svg", ".jpg", ".jpeg"):
            raise ParameterError(f"figure must be .png, .pdf, .svg or .jpg; got {out.name!r}")
        with atomic_path(out) as tmp:
            fig.savefig(tmp, dpi=dpi, format=out.suffix.lstrip(".").lower().replace("jpg", "jpeg"))
    return fig


__all__ = ["plot_motion", "f0_track"]
