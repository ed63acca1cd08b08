"""Framing, deltas, smoothing and length fitting shared by every feature extractor.

Frame convention (the same as :func:`headmotion.align.n_frames` and
:func:`headmotion.align.resample_track`): frame ``t`` at ``fps`` covers ``[t/fps, (t+1)/fps)`` and
its analysis window is centred on ``(t + 0.5) / fps``; samples outside the signal are zeros.  This
works for any frame rate (25, 29.97, 100 fps), which librosa's integer-hop framing
(``librosa.util.frame``) does not, so the windows are gathered here with one vectorised index.

Deltas follow HTK's regression formula (thesis §2.2.4, paper §4.1 "first and second-order
derivatives"): ``d_t = Σ_n n (c_{t+n} − c_{t−n}) / (2 Σ_n n²)`` with ``N = 2``, computed as a
Savitzky–Golay first-derivative filter (written out in numpy: ``scipy.signal`` alone takes seconds
to import) whose edge frames use a fitted line, so the delta of a ramp is the same constant in
every frame.  ΔΔ is the delta of the delta, as in HTK.
"""

from __future__ import annotations

import numpy as np

from ..align import fit_length  # noqa: F401  (re-exported: the one pad/trim helper)
from ..errors import ParameterError


def frame_centres(n_frames: int, sample_rate: float, fps: float) -> np.ndarray:
    """Centre of each frame in samples: ``(t + 0.5) * sample_rate / fps``, shape ``(n_frames,)``."""
    return (np.arange(n_frames) + 0.5) * (sample_rate / fps)


def frame_signal(x: np.ndarray, *, sample_rate: float, fps: float, n_frames: int,
                 win_length: int) -> np.ndarray:
    """Gather analysis windows centred on each frame.

    Parameters
    ----------
    x : np.ndarray [shape=(n,)]
    sample_rate, fps : float
    n_frames : int
    win_length : int, samples per window

    Returns
    -------
    np.ndarray [shape=(n_frames, win_length), dtype=x.dtype]
        Row ``t`` holds ``x[s_t : s_t + win_length]`` with ``s_t = round(c_t − win_length / 2)``,
        zero outside the signal.
    """
    if win_length < 1:
        raise ParameterError(f"win_length must be at least 1 sample; got {win_length}")
    x = np.asarray(x)
    if n_frames <= 0:
        return np.zeros((0, win_length), dtype=x.dtype)
    starts = np.floor(frame_centres(n_frames, sample_rate, fps) - win_length / 2 + 0.5).astype(np.int64)
    left = int(max(0, -starts.min()))
    right = int(max(0, starts.max() + win_length - len(x)))
    xp = np.pad(x, (left, right)) if (left or right) else x
    # rows of a strided view: no (n_frames, win_length) index matrix (8 bytes per sample of output)
    return np.lib.stride_tricks.sliding_window_view(xp, win_length)[starts + left]


#: frames gathered at a time by :func:`frame_chunks` (a chunk of 25 ms windows at 16 kHz: 6.5 MB)
CHUNK_FRAMES = 4096


def frame_chunks(x: np.ndarray, *, sample_rate: float, fps: float, n_frames: int, win_length: int,
                 chunk: int = CHUNK_FRAMES):
    """The rows of :func:`frame_signal` ``chunk`` frames at a time: yields ``(first, frames)``
    with ``frames`` the windows of frames ``first … first + len(frames) − 1`` (the same values),
    so that an analysis of a long recording never holds all its windows at once."""
    if win_length < 1:
        raise ParameterError(f"win_length must be at least 1 sample; got {win_length}")
    x = np.asarray(x)
    starts = np.floor(frame_centres(max(n_frames, 0), sample_rate, fps) - win_length / 2 + 0.5).astype(np.int64)
    for a in range(0, max(n_frames, 0), int(chunk)):
        s = starts[a:a + int(chunk)]
        lo, hi = max(0, int(s[0])), min(len(x), int(s[-1]) + win_length)
        left, right = int(max(0, -s[0])), int(max(0, s[-1] + win_length - len(x)))
        sub = x[lo:max(lo, hi)]
        sp = np.pad(sub, (left, right)) if (left or right) else sub
        yield a, np.lib.stride_tricks.sliding_window_view(sp, win_length)[s - lo + left]


def frame_log_energy_db(x: np.ndarray, *, sample_rate: float, fps: float, n_frames: int, win_length: int,
                        floor_db: float = -100.0) -> np.ndarray:
    """``log_energy_db(frame_signal(x, ...))`` without holding every window at once."""
    out = np.empty(max(n_frames, 0))
    for a, frames in frame_chunks(x, sample_rate=sample_rate, fps=fps, n_frames=n_frames, win_length=win_length):
        out[a:a + len(frames)] = log_energy_db(frames, floor_db=floor_db)
    return out


def deltas(x: np.ndarray, *, width: int = 5) -> np.ndarray:
    """HTK regression deltas along time (axis 0).

    Interior frames: ``d_t = Σ_{n=1..N} n (x_{t+n} − x_{t−n}) / (2 Σ n²)``, ``N = width // 2``.
    The first and last ``N`` frames take the slope of the line fitted to the first / last
    ``width`` frames (scipy's ``savgol_filter(..., polyorder=1, deriv=1, mode="interp")``, written
    out in numpy because importing ``scipy.signal`` costs more than a minute of features), so the
    delta of a ramp is the same constant everywhere.

    Parameters
    ----------
    x : np.ndarray [shape=(T, D)]
    width : int, odd, regression window in frames (5 → N = 2 as in HTK)

    Returns
    -------
    np.ndarray [shape=(T, D)]
    """
    x = np.asarray(x, dtype=np.float64)
    if width < 3 or width % 2 == 0:
        raise ParameterError(f"delta width must be an odd number >= 3; got {width}")
    T = x.shape[0]
    N = width // 2
    if T >= width:
        d = np.zeros_like(x)
        denom = 2.0 * sum(n * n for n in range(1, N + 1))
        for n in range(1, N + 1):
            d[N:T - N] += n * (x[N + n:T - N + n] - x[N - n:T - N - n])
        d /= denom
        d[:N] = d[N]
        d[T - N:] = d[T - N - 1]
        return d
    if T >= 2:
        return np.gradient(x, axis=0)
    return np.zeros_like(x)


def with_deltas(static: np.ndarray, names, *, width: int = 5):
    """``[static, Δ, ΔΔ]`` and names ``[n, d_n, dd_n]``; shapes ``(T, D) -> (T, 3D)``."""
    d1 = deltas(static, width=width)
    d2 = deltas(d1, width=width)
    names = list(names)
    return (np.hstack([static, d1, d2]),
            names + [f"d_{n}" for n in names] + [f"dd_{n}" for n in names])


def moving_average(x: np.ndarray, size: int) -> np.ndarray:
    """Moving average over ``size`` frames along axis 0; edges repeat the end value.

    Frame ``t`` averages ``x[t − size//2 : t − size//2 + size]`` (the window of
    ``scipy.ndimage.uniform_filter1d(mode="nearest")``; for an even size it reaches one frame
    further into the past than into the future)."""
    x = np.asarray(x, dtype=np.float64)
    size = int(size)
    if size <= 1 or len(x) == 0:
        return x
    left = size // 2
    right = size - 1 - left
    xp = np.concatenate([np.repeat(x[:1], left, axis=0), x, np.repeat(x[-1:], right, axis=0)])
    c = np.cumsum(xp, axis=0)
    c = np.concatenate([np.zeros((1,) + x.shape[1:]), c])
    return (c[size:] - c[:-size]) / size




def pre_emphasis(x: np.ndarray, coef: float = 0.97) -> np.ndarray:
    """``y[n] = x[n] − coef · x[n−1]`` (``y[0] = x[0]``)."""
    x = np.asarray(x, dtype=np.float32)
    if coef == 0 or x.size == 0:
        return x
    y = np.empty_like(x)
    y[0] = x[0]
    y[1:] = x[1:] - coef * x[:-1]
    return y


def log_energy_db(frames: np.ndarray, window: np.ndarray | None = None, floor_db: float = -100.0) -> np.ndarray:
    """Mean power of each (windowed) frame in dB re full scale, floored; ``(T, W) -> (T,)``."""
    if window is not None:
        p = np.einsum("tw,w->t", frames.astype(np.float64) ** 2, window ** 2) / np.sum(window ** 2)
    else:
        p = np.mean(frames.astype(np.float64) ** 2, axis=1)
    return np.maximum(10.0 * np.log10(np.maximum(p, 1e-30)), floor_db)


__all__ = ["frame_centres", "frame_signal", "frame_chunks", "frame_log_energy_db", "deltas", "with_deltas", "moving_average", "fit_length",
           "pre_emphasis", "log_energy_db"]
