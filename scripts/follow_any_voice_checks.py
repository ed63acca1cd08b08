#!/usr/bin/env python
"""Per-file checks of a model on speech with no recorded head (docs/decisions/follow-any-voice.md):

* **amount**: the SD of the motion (root mean square of the per-axis SDs, degrees; mean of seeds
  0–3) at ``--amount`` 0.5, 1, 2 and 3 — it should grow with the amount on every file;
* **takes**: the mean pairwise correlation of the 4 takes' pitch, yaw and roll at amount 1
  (different takes: ≤ 0.5 per axis);
* **opening**: how far from the model's mean pose the first frame is, and the largest distance over
  the first 0.3 s (degrees, any axis, any amount, any seed).

    python scripts/follow_any_voice_checks.py default stream --speech ../shared/data/speech \\
        ../shared/data/mocap_speech/zeggs/067_Speech_2_x_1_0.wav
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

AMOUNTS = (0.5, 1.0, 2.0, 3.0)
SEEDS = (0, 1, 2, 3)


def check(model, audio) -> dict:
    import headmotion
    from headmotion.rotations import rotvec_to_pitch_yaw_roll

    mean = np.degrees(np.asarray(getattr(model, "mean_pose_", np.zeros(3)), dtype=float))
    sds, first, early, takes = [], 0.0, 0.0, None
    for amount in AMOUNTS:
        per = []
        for s in SEEDS:
            m = headmotion.synthesize(audio, model, seed=s, amount=amount)[0]
            pyr = np.degrees(np.asarray(rotvec_to_pitch_yaw_roll(m.rotvec)))
            per.append(pyr)
            first = max(first, float(np.abs(pyr[0] - mean).max()))
            early = max(early, float(np.abs(pyr[:max(1, int(0.3 * m.fps))] - mean).max()))
        sds.append(float(np.mean([np.sqrt(np.mean(p.std(axis=0) ** 2)) for p in per])))
        if amount == 1.0:
            n = min(len(p) for p in per)
            takes = [float(np.mean([np.corrcoef(per[i][:n, k], per[j][:n, k])[0, 1]
                                    for i in range(len(per)) for j in range(i + 1, len(per))])) for k in range(3)]
    return {"sd": sds, "monotone": all(a < b for a, b in zip(sds, sds[1:])), "takes": takes,
            "first": first, "early": early}


def main(argv=None) -> int:
    import headmotion
    from headmotion.io import load_audio

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="+", help="shipped names or model files")
    ap.add_argument("--speech", nargs="+", type=Path, required=True, help="speech files or folders")
    a = ap.parse_args(argv)
    files = []
    for p in a.speech:
        files += sorted(f for f in p.iterdir() if f.suffix.lower() in (".wav", ".flac", ".mp3")) if p.is_dir() else [p]
    warnings.simplefilter("ignore")
    for name in a.models:
        model = headmotion.load_model(name)
        print(f"\n{name}\n\n| file | SD at amount 0.5 / 1 / 2 / 3 (°) | grows | take correlation p/y/r | "
              "first frame / first 0.3 s from the mean pose (°) |\n|---|---|---|---|---|")
        bad, high = 0, 0
        for f in files:
            r = check(model, load_audio(f, sample_rate=16000))
            bad += not r["monotone"]
            high += max(r["takes"]) > 0.5
            print(f"| {f.name} | {' / '.join(f'{x:.2f}' for x in r['sd'])} | {'yes' if r['monotone'] else '**no**'} | "
                  f"{'/'.join(f'{x:.2f}' for x in r['takes'])} | {r['first']:.1f} / {r['early']:.1f} |", flush=True)
        print(f"\n{len(files) - bad} of {len(files)} files grow with the amount; {high} have an axis whose takes "
              "correlate above 0.5")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
