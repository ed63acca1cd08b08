"""f0e-live (per-frame YIN, streaming) against the offline f0e (Praat) on ../shared/data/speech.

    python benchmarks/compare_f0e_live.py [SECONDS]

Per file (first SECONDS, default 30, at 16 kHz, 100 fps): voiced fractions of both trackers and
their agreement; on frames both call voiced, the correlation of raw log F0, the median absolute
difference in semitones and the share of frames more than a semitone apart; then the correlation
of each of the six final feature columns (f0e-live defaults against f0e defaults).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from headmotion.features import extract
from headmotion.features.prosody import praat_pitch
from headmotion.features.streaming import f0e_live
from headmotion.io import load_audio
from headmotion.types import Audio

SPEECH = Path(__file__).resolve().parents[2] / "shared" / "data" / "speech"


def main() -> None:
    seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 30.0
    files = sorted(p for p in SPEECH.iterdir() if p.suffix in (".wav", ".flac"))
    print("file | voiced praat / yin / agree | raw log F0 on both voiced: r, median |Δ| st, >1 st | "
          "final columns r: logf0 energy d_logf0 d_energy dd_logf0 dd_energy")
    for f in files:
        a = load_audio(f, sample_rate=16000)
        A = Audio(a.samples[: int(seconds * 16000)], 16000)
        T = len(A.samples) // 160
        v, _ = f0e_live(A, fps=100, n_frames=T, smooth_frames=1, voicing=True)
        f0, pv = praat_pitch(A, fps=100, n_frames=T, pitch_step=0.01)
        yv = v[:, 6] > 0
        both = yv & pv
        r = np.corrcoef(v[both, 0], np.log(f0[both]))[0, 1]
        st = 12 * np.abs(v[both, 0] - np.log(f0[both])) / np.log(2)
        L, O = extract("f0e-live", A).values, extract("f0e", A).values
        cols = " ".join(f"{np.corrcoef(L[:, j], O[:, j])[0, 1]:.2f}" for j in range(6))
        print(f"{f.name[:24]:24s} | {pv.mean():.2f} / {yv.mean():.2f} / {np.mean(yv == pv):.2f} | "
              f"{r:.3f}, {np.median(st):.2f}, {np.mean(st > 1):.2f} | {cols}")


if __name__ == "__main__":
    main()
