"""Planted-structure corpora: real speech with head motion made by a *known* template-warping
process driven by that speech (for tests and benchmarks of every system; thesis §5.1–5.5).

The planted process, per rotation axis, is causal template warping (eq 5.1/5.2, alternating
rising/falling half-cosines, offset by continuity).  At each change point it reads the speech
loudness ``e`` (0 = silence … 1 = loud, from the frame log-energy) averaged over the 10 frames
before the change, and sets

* the duration  ``d = d_axis * (1.6 - 0.9 e)``  seconds (louder speech → faster movements),
* the end value ``B_axis (e - 0.4) ± A_axis (0.15 + e)`` (alternating sign): the amplitude follows
  loudness and the centre of the oscillation shifts with it (the head pitches down when loud), so
  motion and speech features are also linearly correlated, as FCCA (thesis eq 4.5) measures,

plus small multiplicative noise.  Motion therefore depends on the speech features in a way any
speech-driven system can learn, while silence gives slow, small motion.  Speech comes from real
audio files: the package's ``examples/speech/*.wav`` (espeak-ng, our own), or any directory given
(e.g. ``../shared/data/speech``); long corpora tile the sources with random crops, gains and
order so 5–60 minutes are made in seconds.

Library considered: none (this is the test oracle of the template-warping systems).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .corpus import Corpus, Recording
from .errors import ParameterError
from .motion.templates import template_shape
from .types import Audio, Motion

#: per-axis base duration (s) and amplitude (rad): pitch nods fastest, roll smallest
AXIS_DURATION_S = (0.32, 0.45, 0.40)
AXIS_AMPLITUDE_RAD = (0.06, 0.08, 0.035)
#: per-axis shift of the oscillation centre with loudness (rad): the head pitches down when loud
AXIS_CENTRE_RAD = (0.10, 0.05, 0.02)
CONTEXT_FRAMES = 10
AUDIO_EXTENSIONS = (".wav", ".flac", ".ogg", ".mp3")


def _repo_examples() -> Path:
    return Path(__file__).resolve().parents[2] / "examples" / "speech"


def speech_sources(directory=None) -> list[Path]:
    """Audio files to drive planted corpora: ``directory``, else the bundled examples, else
    ``../shared/data/speech`` next to the repository (when present)."""
    cands = []
    if directory is not None:
        cands.append(Path(directory))
    else:
        cands += [_repo_examples(), Path(__file__).resolve().parents[3] / "shared" / "data" / "speech"]
    for d in cands:
        if d.is_dir():
            files = sorted(p for p in d.iterdir() if p.suffix.lower() in AUDIO_EXTENSIONS)
            if files:
                return files
    raise ParameterError(f"no speech audio found for a planted corpus; looked in {[str(c) for c in cands]}")


def loudness(audio: Audio, *, fps: float, n_frames: int) -> np.ndarray:
    """Frame loudness in [0, 1]: log energy over 25 ms windows, 0 at 45 dB below the peak."""
    x = np.asarray(audio.samples, dtype=np.float64)
    sr = audio.sample_rate
    hop = sr / fps
    win = int(round(0.025 * sr))
    centres = (np.arange(n_frames) + 0.5) * hop
    c2 = np.concatenate([[0.0], np.cumsum(x * x)])
    a = np.clip((centres - win / 2).astype(np.int64), 0, len(x))
    b = np.clip((centres + win / 2).astype(np.int64), 0, len(x))
    energy = (c2[b] - c2[a]) / np.maximum(b - a, 1)
    db = 10 * np.log10(energy + 1e-10)
    top = np.percentile(db, 99) if len(db) else 0.0
    return np.clip((db - (top - 45.0)) / 45.0, 0.0, 1.0)


def planted_rotvec(e: np.ndarray, *, fps: float, rng: np.random.Generator, noise: float = 0.1) -> np.ndarray:
    """The planted process: (T, 3) rotation from loudness ``e`` (T,)."""
    T = len(e)
    out = np.zeros((T, 3))
    ce = np.concatenate([[0.0], np.cumsum(e)])
    for j in range(3):
        t, c, sign = 0, 0.0, 1.0 if j != 1 else -1.0
        durs, amps = [], []
        while t < T - 1:
            lo = max(0, t - CONTEXT_FRAMES)
            ctx = (ce[t] - ce[lo]) / max(t - lo, 1) if t > 0 else e[0]
            d = AXIS_DURATION_S[j] * (1.6 - 0.9 * ctx) * float(np.exp(noise * rng.standard_normal()))
            d = max(d * fps, 0.07 * fps)
            centre = AXIS_CENTRE_RAD[j] * (ctx - 0.4)
            amp = AXIS_AMPLITUDE_RAD[j] * (0.15 + ctx) * float(np.exp(noise * rng.standard_normal()))
            # templates alternate: a rising segment must rise (at least a fifth of its amplitude)
            end = c + sign * max(sign * (centre + sign * amp - c), 0.2 * amp)
            durs.append(d)
            amps.append(end - c)
            c = end
            sign = -sign
            t = int(np.floor(sum(durs)))
        d = np.asarray(durs)
        s = np.asarray(amps)
        ends = np.cumsum(d)
        starts = ends - d
        tt = np.arange(T, dtype=np.float64)
        k = np.minimum(np.searchsorted(ends, tt), len(d) - 1)
        offs = np.concatenate([[0.0], np.cumsum(s)[:-1]])
        out[:, j] = offs[k] + s[k] * template_shape(np.clip((tt - starts[k]) / d[k], 0, 1))
    return out


def planted_motion(audio: Audio, *, fps: float = 100.0, seed: int = 0) -> Motion:
    """Head motion for ``audio`` made by the planted process (deterministic given ``seed``)."""
    from .align import n_frames as _n

    T = _n(len(audio), audio.sample_rate, fps)
    e = loudness(audio, fps=fps, n_frames=T)
    rv = planted_rotvec(e, fps=fps, rng=np.random.default_rng(seed))
    return Motion(rv, fps, meta={"source": "planted template-warping process"})


def _load(path, sample_rate: int) -> Audio:
    try:
        from .io import load_audio
    except ImportError:  # io package incomplete (development): plain soundfile + soxr
        import soundfile as sf
        import soxr

        x, sr = sf.read(str(path), dtype="float32", always_2d=True)
        x = x.mean(axis=1)
        if sr != sample_rate:
            x = soxr.resample(x, sr, sample_rate)
        return Audio(x.astype(np.float32), sample_rate)
    return load_audio(path, sample_rate=sample_rate)


def _speech_pool(sources, sample_rate: int) -> list[np.ndarray]:
    pool = []
    for p in sources:
        a = _load(p, sample_rate)
        if a.duration >= 0.5:
            pool.append(np.asarray(a.samples, dtype=np.float32))
    if not pool:
        raise ParameterError("no usable speech (>= 0.5 s) in the planted-corpus sources")
    return pool


def tiled_speech(pool: list[np.ndarray], seconds: float, *, sample_rate: int, rng) -> np.ndarray:
    """Concatenate random crops of the pool, with random gains and short pauses, to ``seconds``."""
    n = int(round(seconds * sample_rate))
    parts, got = [], 0
    while got < n:
        src = pool[int(rng.integers(len(pool)))]
        L = len(src)
        ln = int(min(L, rng.uniform(2.0, 8.0) * sample_rate))
        st = int(rng.integers(0, max(L - ln, 0) + 1))
        seg = src[st:st + ln] * np.float32(10 ** (rng.uniform(-6, 3) / 20))
        pause = np.zeros(int(rng.uniform(0.1, 0.8) * sample_rate), dtype=np.float32)
        parts += [seg, pause]
        got += len(seg) + len(pause)
    x = np.concatenate(parts)[:n]
    peak = float(np.max(np.abs(x))) if n else 0.0
    if peak > 0.99:
        x = x * np.float32(0.99 / peak)
    return x


def planted_corpus(*, minutes: float = 2.0, n_recordings: int = 4, speakers=("planted",),
                   fps: float = 100.0, seed: int = 0, speech_dir=None, sample_rate: int = 16000) -> Corpus:
    """An in-memory corpus of tiled real speech with planted head motion.

    Parameters
    ----------
    minutes : total length (split evenly over recordings)
    n_recordings : recordings per speaker
    speakers : speaker names (each gets ``n_recordings`` takes; the process is the same)
    fps : motion frame rate
    seed : controls speech tiling and motion noise
    speech_dir : directory of speech audio (default: bundled examples or ../shared/data/speech)
    """
    if minutes <= 0 or n_recordings < 1:
        raise ParameterError(f"planted_corpus needs minutes > 0 and n_recordings >= 1; got {minutes}, {n_recordings}")
    rng = np.random.default_rng(seed)
    pool = _speech_pool(speech_sources(speech_dir), sample_rate)
    recs = []
    per = minutes * 60.0 / (n_recordings * len(speakers))
    for spk in speakers:
        for i in range(n_recordings):
            x = tiled_speech(pool, per, sample_rate=sample_rate, rng=rng)
            audio = Audio(x, sample_rate)
            motion = planted_motion(audio, fps=fps, seed=int(rng.integers(1 << 31)))
            recs.append(Recording.aligned(f"{spk}_{i:03d}", spk, "read" if i % 2 == 0 else "free", audio, motion))
    return Corpus(recs, sample_rate=sample_rate)


__all__ = ["planted_corpus", "planted_motion", "planted_rotvec", "loudness", "speech_sources", "tiled_speech"]
