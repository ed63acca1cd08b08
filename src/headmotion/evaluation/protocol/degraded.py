"""Degraded copies of speech: what a user's own recordings sound like (the seeds are silent).

A model that follows clean studio speech may still fail on a phone call, a quiet recording or a
compressed file.  Each degradation is a function ``Audio -> Audio`` at the input's rate, seeded
where it draws noise:

``noise20``
    white Gaussian noise at 20 dB SNR (speech power over the whole file).
``telephone``
    the narrow band of a telephone line: a 4th-order Butterworth band-pass at 300–3400 Hz on a
    copy resampled to 8 kHz (``scipy.signal``, soxr), then back to the input's rate.
``quiet``
    −20 dB: the level of a distant or badly set microphone.
``mp3-64k``
    MP3 at 64 kbit/s through PyAV's LAME encoder and decoded again (the codec's delay removed:
    the copy starts with the original).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...errors import ParameterError
from ...types import Audio


def add_noise(audio: Audio, snr_db: float = 20.0, *, seed: int = 0) -> Audio:
    """``audio`` plus white Gaussian noise at ``snr_db`` (signal power over the whole file)."""
    x = np.asarray(audio.samples, dtype=np.float64)
    power = float(np.mean(x * x)) if len(x) else 0.0
    noise = np.random.default_rng(seed).standard_normal(len(x)) * np.sqrt(power / 10.0 ** (snr_db / 10.0))
    return Audio(np.clip(x + noise, -1.0, 1.0).astype(np.float32), audio.sample_rate)


def telephone(audio: Audio, *, low_hz: float = 300.0, high_hz: float = 3400.0) -> Audio:
    """A telephone line: 8 kHz, band-passed at ``low_hz``–``high_hz``, back at the input's rate."""
    import soxr
    from scipy.signal import butter, sosfilt

    x = np.asarray(audio.samples, dtype=np.float64)
    narrow = soxr.resample(x, audio.sample_rate, 8000) if audio.sample_rate != 8000 else x
    band = sosfilt(butter(4, [low_hz, high_hz], btype="bandpass", fs=8000, output="sos"), narrow)
    back = soxr.resample(band, 8000, audio.sample_rate) if audio.sample_rate != 8000 else band
    out = np.zeros(len(x))
    out[:min(len(x), len(back))] = back[:len(x)]
    return Audio(np.clip(out, -1.0, 1.0).astype(np.float32), audio.sample_rate)


def gain(audio: Audio, db: float = -20.0) -> Audio:
    """``audio`` scaled by ``db`` decibels."""
    x = np.asarray(audio.samples, dtype=np.float64) * 10.0 ** (db / 20.0)
    return Audio(np.clip(x, -1.0, 1.0).astype(np.float32), audio.sample_rate)


def mp3(audio: Audio, *, bitrate: int = 64000) -> Audio:
    """``audio`` encoded as MP3 at ``bitrate`` bit/s (LAME, through PyAV) and decoded again, trimmed
    to the input's length from the first sample the encoder delayed."""
    import io

    import av

    rate = int(audio.sample_rate)
    if rate not in (8000, 11025, 12000, 16000, 22050, 24000, 32000, 44100, 48000):
        raise ParameterError(f"MP3 takes 8–48 kHz audio at a standard rate; got {rate} Hz")
    x = np.clip(np.asarray(audio.samples, dtype=np.float32), -1.0, 1.0)
    buf = io.BytesIO()
    with av.open(buf, "w", format="mp3") as out:
        stream = out.add_stream("libmp3lame", rate=rate)
        stream.bit_rate = int(bitrate)
        stream.layout = "mono"
        frame = av.AudioFrame.from_ndarray(x[None, :], format="flt", layout="mono")
        frame.sample_rate = rate
        for packet in stream.encode(frame):
            out.mux(packet)
        for packet in stream.encode(None):
            out.mux(packet)
    buf.seek(0)
    parts = []
    with av.open(buf, "r") as inp:
        for fr in inp.decode(audio=0):
            a = fr.to_ndarray().astype(np.float64)
            parts.append(a.mean(axis=0) if a.ndim == 2 and a.shape[0] > 1 else a.reshape(-1))
    y = np.concatenate(parts) if parts else np.zeros(0)
    # the decoder drops LAME's padding when the stream says so; find any delay left by correlation
    lag = _delay(x.astype(np.float64), y, max_lag=4096)
    y = y[lag:lag + len(x)]
    out_x = np.zeros(len(x))
    out_x[:len(y)] = y
    return Audio(np.clip(out_x, -1.0, 1.0).astype(np.float32), rate)


def _delay(x: np.ndarray, y: np.ndarray, *, max_lag: int) -> int:
    """The lag (0 … ``max_lag``) at which ``y`` matches ``x`` best (cross-correlation of the first
    second)."""
    n = min(len(x), len(y) - max_lag, 16000)
    if n <= 0:
        return 0
    best = [float(np.dot(x[:n], y[k:k + n])) for k in range(max_lag + 1)]
    return int(np.argmax(best))


#: the degradations by name (:func:`degrade`)
DEGRADATIONS: dict[str, Callable[[Audio], Audio]] = {
    "noise20": lambda a: add_noise(a, 20.0, seed=0),
    "telephone": telephone,
    "quiet": lambda a: gain(a, -20.0),
    "mp3-64k": lambda a: mp3(a, bitrate=64000),
}


def check_degradation(name: str) -> str:
    """``name`` when it is ``"clean"`` or one of :data:`DEGRADATIONS`, else ParameterError."""
    if name != "clean" and name not in DEGRADATIONS:
        raise ParameterError(f"unknown degradation {name!r}; expected clean or one of {sorted(DEGRADATIONS)}")
    return name


def degrade(audio: Audio, name: str) -> Audio:
    """``audio`` degraded by the named degradation (:data:`DEGRADATIONS`; ``"clean"``: unchanged)."""
    if check_degradation(name) == "clean":
        return audio
    return DEGRADATIONS[name](audio)


__all__ = ["add_noise", "telephone", "gain", "mp3", "degrade", "check_degradation", "DEGRADATIONS"]
