"""Make the example listening-test stimuli (run from anywhere: ``python make_stimuli.py``).

Speech: espeak-ng (``apt-get install espeak-ng``), two synthetic "speakers".  Motion: generated in
numpy from the speech envelope, so everything here is of the project's own making:

* ``natural``  — nods that follow the syllable energy plus a slow sway (plays the motion capture);
* ``system``   — the natural motion, delayed by 0.2 s, smoothed and scaled (a plausible synthesis);
* ``desync``   — the natural motion of another sentence (natural but not synchronised, thesis §4.2.3);
* ``noise``    — head-motion shaped noise (thesis §4.2.4.1: white noise filtered by the magnitude
  spectrum of the natural motion, then five-point Gaussian smoothing), the anchor.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import soundfile as sf

HERE = Path(__file__).resolve().parent
FPS = 25.0
SR = 16000
SENTENCES = {
    "s1": ("en-gb", "Head motion helps us understand who is speaking and what they mean."),
    "s2": ("en-gb", "We recorded several short sentences for this small example test."),
    "s3": ("en-us+f3", "Please watch the head carefully and ignore the synthetic voice."),
    "s4": ("en-us+f3", "A natural nod often falls on the stressed syllable of a word."),
}
SPEAKER = {"en-gb": "A", "en-us+f3": "B"}


def speak(text: str, voice: str) -> np.ndarray:
    tmp = HERE / ".tmp.wav"
    subprocess.run(["espeak-ng", "-v", voice, "-s", "150", "-w", str(tmp), text], check=True)
    y, sr = sf.read(tmp, dtype="float32")
    tmp.unlink()
    import soxr

    return soxr.resample(y, sr, SR).astype(np.float32)


def envelope(y: np.ndarray) -> np.ndarray:
    hop = int(SR / FPS)
    n = len(y) // hop
    e = np.sqrt(np.mean(y[: n * hop].reshape(n, hop) ** 2, axis=1))
    return e / (e.max() + 1e-9)


def smooth(x: np.ndarray, width: float) -> np.ndarray:
    k = np.exp(-0.5 * (np.arange(-3 * width, 3 * width + 1) / width) ** 2)
    k /= k.sum()
    return np.stack([np.convolve(np.pad(c, len(k) // 2, mode="edge"), k, "valid") for c in x.T], 1)


def natural(e: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    t = np.arange(len(e)) / FPS
    onset = np.clip(np.diff(e, prepend=0), 0, None)
    pitch = 0.12 * smooth(onset[:, None], 2)[:, 0] * 6
    yaw = 0.08 * np.sin(2 * np.pi * 0.3 * t + rng.uniform(0, 6)) + 0.03 * smooth(e[:, None], 4)[:, 0]
    roll = 0.03 * np.sin(2 * np.pi * 0.17 * t + rng.uniform(0, 6))
    return np.stack([pitch, yaw, roll], 1)


def shaped_noise(m: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    spec = np.abs(np.fft.rfft(m - m.mean(0), axis=0))
    w = np.fft.rfft(rng.standard_normal(m.shape), axis=0)
    out = np.fft.irfft(w * spec / np.sqrt(len(m)), n=len(m), axis=0)
    g = np.exp(-0.5 * np.arange(-2, 3) ** 2)
    g /= g.sum()
    return np.stack([np.convolve(np.pad(c, 2, mode="edge"), g, "valid") for c in out.T], 1)


def main() -> None:
    rng = np.random.default_rng(7)
    (HERE / "audio").mkdir(exist_ok=True)
    (HERE / "motion").mkdir(exist_ok=True)
    nat = {}
    for sid, (voice, text) in SENTENCES.items():
        y = speak(text, voice)
        sf.write(HERE / "audio" / f"{sid}.wav", y, SR, subtype="PCM_16")
        nat[sid] = natural(envelope(y), rng)
    ids = list(SENTENCES)
    for i, sid in enumerate(ids):
        m = nat[sid]
        T = len(m)
        lag = int(0.2 * FPS)
        system = 0.8 * smooth(np.concatenate([np.repeat(m[:1], lag, 0), m[:-lag]]), 2)
        other = nat[ids[(i + 1) % len(ids)] if SENTENCES[ids[(i + 1) % len(ids)]][0] == SENTENCES[sid][0] else ids[i - 1]]
        desync = np.resize(other, (T, 3)) if len(other) < T else other[:T]
        noise = shaped_noise(m, rng)
        for name, rot in {"natural": m, "system": system, "desync": desync, "noise": noise}.items():
            np.savez_compressed(HERE / "motion" / f"{sid}_{name}.npz", rotvec=rot.astype(np.float64),
                                fps=np.float64(FPS))
    print("written", sorted(p.name for p in (HERE / "motion").iterdir()))


if __name__ == "__main__":
    main()
