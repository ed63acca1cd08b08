"""Raw waveform frames (paper §4.1): resample to 4 kHz, 25 ms windows, 10 ms shift → 100 dims.

The input of the CCCAE (paper §3.1).  Frame ``t`` holds the 100 samples of the 4 kHz signal centred
on ``(t + 0.5) / fps`` (zeros outside the signal), so at 100 fps the middle 40 samples of
consecutive frames tile the resampled signal exactly.  Resampling uses soxr (high quality), as
everywhere in headmotion; no window function is applied (the paper feeds the raw samples).
"""

from __future__ import annotations

from ..io.audio import resample
from ..types import Audio
from .frames import frame_signal


def wav(audio: Audio, *, fps: float, n_frames: int, sample_rate: int = 4000, window_s: float = 0.025):
    """Raw waveform windows, ``(T, 100)`` at the defaults.

    Parameters
    ----------
    audio : Audio
    fps : float
    n_frames : int
    sample_rate : int, Hz, rate the signal is resampled to (4000 in the paper)
    window_s : float, window length in seconds (25 ms → 100 samples at 4 kHz)

    Returns
    -------
    values : np.ndarray [shape=(T, round(window_s * sample_rate))]
    names : ``s000 .. s099``
    """
    y = resample(audio.samples, audio.sample_rate, int(sample_rate))
    win = max(1, int(round(window_s * sample_rate)))
    frames = frame_signal(y, sample_rate=sample_rate, fps=fps, n_frames=n_frames, win_length=win)
    return frames, [f"s{i:03d}" for i in range(win)]


__all__ = ["wav"]
