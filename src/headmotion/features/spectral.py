"""MFCC-39 and FBank-27 (paper §4.1 and §4.3; thesis §2.2.4).

* :func:`mfcc` — ``[energy, c1..c12]`` + Δ + ΔΔ = 39 dims, the HTK/SPTK recipe the paper used:
  pre-emphasis 0.97, 25 ms Hamming window centred on each frame (10 ms shift at 100 fps), power
  spectrum, 26 triangular mel filters (HTK mel scale, unnormalised), log, DCT-II (orthonormal),
  cepstral liftering 22; ``energy`` is the natural log of the raw frame energy (HTK ``E``).
* :func:`fbank` — the 26 log mel-filter energies + log energy = 27 dims (paper §4.3), no deltas.

Library: librosa was the first choice.  ``librosa.feature.mfcc`` frames with an integer hop from
the start of the signal, so it cannot give frames centred on ``(t+0.5)/fps`` at 29.97 fps; and
importing librosa costs ~2.5 s of CPU (scipy.signal, numba), more than extracting features of ten
minutes of speech, which matters for ``headmotion synth`` on a short clip.  So the short pipeline is
vectorised numpy on top of :func:`~headmotion.features.frames.frame_signal`; the mel filterbank
and A-weighting are re-implemented and tested equal to ``librosa.filters.mel(htk=True, norm=None)``
and ``librosa.A_weighting``; the DCT is ``scipy.fft.dct``.
"""

from __future__ import annotations

import functools

import numpy as np

from ..types import Audio
from .frames import frame_chunks, frame_signal, pre_emphasis, with_deltas

LOG_FLOOR = 1e-10


def hz_to_mel(f):
    """HTK mel scale ``2595 log10(1 + f / 700)``."""
    return 2595.0 * np.log10(1.0 + np.asarray(f, dtype=np.float64) / 700.0)


def mel_to_hz(m):
    return 700.0 * (10.0 ** (np.asarray(m, dtype=np.float64) / 2595.0) - 1.0)


@functools.lru_cache(maxsize=16)
def _mel_bank(sample_rate: int, n_fft: int, n_mels: int):
    """Triangular HTK-mel filterbank, ``(n_mels, n_fft // 2 + 1)``, peak 1, and band centres (Hz).

    Identical to ``librosa.filters.mel(sr, n_fft=n_fft, n_mels=n_mels, htk=True, norm=None)``
    (tested); written out because importing librosa (scipy.signal, numba) costs ~2.5 s of CPU,
    more than the features of ten minutes of speech."""
    fft_freqs = np.linspace(0.0, sample_rate / 2.0, n_fft // 2 + 1)
    edges = mel_to_hz(np.linspace(hz_to_mel(0.0), hz_to_mel(sample_rate / 2.0), n_mels + 2))
    fdiff = np.diff(edges)
    ramps = edges[:, None] - fft_freqs[None, :]
    lower = -ramps[:-2] / fdiff[:-1, None]
    upper = ramps[2:] / fdiff[1:, None]
    bank = np.maximum(0.0, np.minimum(lower, upper))
    bank.setflags(write=False)
    centres = edges[1:-1].copy()
    return bank, centres


def a_weighting_db(freqs) -> np.ndarray:
    """IEC 61672 A-weighting in dB (as ``librosa.A_weighting``, min -80 dB)."""
    f2 = np.asarray(freqs, dtype=np.float64) ** 2
    c = np.array([12194.217, 20.598997, 107.65265, 737.86223]) ** 2
    w = 2.0 + 20.0 * (np.log10(c[0]) + 2 * np.log10(np.maximum(f2, 1e-30))
                      - np.log10(f2 + c[0]) - np.log10(f2 + c[1])
                      - 0.5 * np.log10(f2 + c[2]) - 0.5 * np.log10(f2 + c[3]))
    return np.maximum(w, -80.0)


def _frames(audio: Audio, fps: float, n_frames: int, window_s: float, pre_emph: float):
    win = max(2, int(round(window_s * audio.sample_rate)))
    raw = frame_signal(audio.samples, sample_rate=audio.sample_rate, fps=fps, n_frames=n_frames,
                       win_length=win)
    x = pre_emphasis(audio.samples, pre_emph) if pre_emph else audio.samples
    emph = frame_signal(x, sample_rate=audio.sample_rate, fps=fps, n_frames=n_frames,
                        win_length=win) if pre_emph else raw
    return raw, emph, win


def _mel_power_of(emph: np.ndarray, win: int, bank: np.ndarray, n_fft: int) -> np.ndarray:
    from scipy.fft import rfft

    spec = rfft(emph.astype(np.float32) * np.hamming(win).astype(np.float32)[None, :], n=n_fft, axis=1)
    pspec = (spec.real ** 2 + spec.imag ** 2).astype(np.float64)
    return pspec @ bank.T


def mel_power(audio: Audio, *, fps: float, n_frames: int, n_mels: int = 26, window_s: float = 0.025,
              pre_emph: float = 0.97, raw_frames: bool = False):
    """Mel-filterbank power per frame.

    Returns
    -------
    power : np.ndarray [shape=(T, n_mels)]
    centres : np.ndarray [shape=(n_mels,)], band centre frequencies in Hz
    (raw : np.ndarray [shape=(T, win)] the un-emphasised frames, when ``raw_frames``)
    """
    raw, emph, win = _frames(audio, fps, n_frames, window_s, pre_emph)
    n_fft = 1 << int(np.ceil(np.log2(win)))
    bank, centres = _mel_bank(int(audio.sample_rate), n_fft, int(n_mels))
    power = _mel_power_of(emph, win, bank, n_fft)
    return (power, centres, raw) if raw_frames else (power, centres)


def _mel_and_log_energy(audio: Audio, *, fps: float, n_frames: int, n_mels: int, window_s: float,
                        pre_emph: float) -> tuple[np.ndarray, np.ndarray]:
    """Mel power ``(T, n_mels)`` and log energy ``(T,)`` of every frame, a chunk of frames at a
    time (:func:`~headmotion.features.frames.frame_chunks`; each frame's values are what
    :func:`mel_power` gives, to the rounding of the mel matrix product, which may depend on the
    number of rows: ~1e-14 relative)."""
    win = max(2, int(round(window_s * audio.sample_rate)))
    n_fft = 1 << int(np.ceil(np.log2(win)))
    bank, _ = _mel_bank(int(audio.sample_rate), n_fft, int(n_mels))
    x = np.asarray(audio.samples)
    emph_x = pre_emphasis(x, pre_emph) if pre_emph else x
    power = np.empty((max(n_frames, 0), int(n_mels)))
    energy = np.empty(max(n_frames, 0))
    opts = dict(sample_rate=audio.sample_rate, fps=fps, n_frames=n_frames, win_length=win)
    for (a, raw), (_, emph) in zip(frame_chunks(x, **opts), frame_chunks(emph_x, **opts)):
        power[a:a + len(raw)] = _mel_power_of(emph, win, bank, n_fft)
        energy[a:a + len(raw)] = _log_energy(raw)
    return power, energy


def _log_energy(raw: np.ndarray) -> np.ndarray:
    return np.log(np.maximum(np.sum(raw.astype(np.float64) ** 2, axis=1), LOG_FLOOR))


def mfcc(audio: Audio, *, fps: float, n_frames: int, n_ceps: int = 12, n_mels: int = 26,
         window_s: float = 0.025, pre_emph: float = 0.97, lifter: int = 22, deltas: bool = True):
    """Energy + ``n_ceps`` mel cepstra (+ Δ + ΔΔ): ``(T, 39)`` by default.

    Returns
    -------
    values : np.ndarray [shape=(T, 3 * (n_ceps + 1))] (``(T, n_ceps + 1)`` without deltas)
    names : ``energy, c1..c12, d_energy, d_c1.., dd_energy, dd_c1..``
    """
    from scipy.fft import dct

    power, energy = _mel_and_log_energy(audio, fps=fps, n_frames=n_frames, n_mels=n_mels, window_s=window_s,
                                        pre_emph=pre_emph)
    logmel = np.log(np.maximum(power, LOG_FLOOR))
    ceps = dct(logmel, type=2, norm="ortho", axis=1)[:, 1:n_ceps + 1]
    if lifter:
        n = np.arange(1, n_ceps + 1)
        ceps = ceps * (1.0 + (lifter / 2.0) * np.sin(np.pi * n / lifter))[None, :]
    static = np.hstack([energy[:, None], ceps])
    names = ["energy"] + [f"c{i}" for i in range(1, n_ceps + 1)]
    if not deltas:
        return static, names
    return with_deltas(static, names)


def fbank(audio: Audio, *, fps: float, n_frames: int, n_mels: int = 26, window_s: float = 0.025,
          pre_emph: float = 0.97):
    """Log mel-filterbank energies + log energy: ``(T, n_mels + 1)`` = 27 by default.

    Returns
    -------
    values : np.ndarray [shape=(T, n_mels + 1)]
    names : ``mel01..mel26, energy`` (bands from low to high frequency)
    """
    power, energy = _mel_and_log_energy(audio, fps=fps, n_frames=n_frames, n_mels=n_mels, window_s=window_s,
                                        pre_emph=pre_emph)
    logmel = np.log(np.maximum(power, LOG_FLOOR))
    names = [f"mel{i:02d}" for i in range(1, n_mels + 1)] + ["energy"]
    return np.hstack([logmel, energy[:, None]]), names


__all__ = ["mfcc", "fbank", "mel_power", "hz_to_mel", "mel_to_hz", "a_weighting_db"]
