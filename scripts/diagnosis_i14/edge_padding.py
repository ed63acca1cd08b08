"""The default model at the end of a clip (issue 14, sixth session): real speech cut mid-utterance
at every 1.37 s, the last 0.25 s of the cut clip's synthesis against the same frames of the uncut
file's, with the regressor's context padded beyond the end by holding the edge frame (as in
training) or by mirroring (the synthesis since this session, ``models/numpy_nets.SYNTHESIS_PAD``).

    PYTHONPATH=src python scripts/diagnosis_i14/edge_padding.py [--model M]

Prints, per padding: the mean and largest deviation (degrees, per axis and frame) and the top
speed in the last 0.25 s.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from headmotion.io import load_audio
from headmotion.models import numpy_nets as nets
from headmotion.rotations import rotvec_to_pitch_yaw_roll
from headmotion.systems import load_model
from headmotion.types import Audio

SPEECH = Path(__file__).resolve().parents[2].parent / "shared/data/speech"
FILES = ["2_scott_0_103_103_28s.wav", "RD_Radio34_002.wav", "chinese_news.wav", "jfk.flac"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", default=str(Path(__file__).resolve().parents[2] / "src/headmotion/data/default_model.hmz"))
    a = ap.parse_args()
    m = load_model(a.model)
    keep = nets.SYNTHESIS_PAD
    for mode in nets.PAD_MODES:
        nets.SYNTHESIS_PAD = mode
        rows = []
        for f in FILES:
            au = load_audio(SPEECH / f)
            full = np.degrees(rotvec_to_pitch_yaw_roll(m.predict(au, seed=0).rotvec))
            for cut in np.arange(3.0, au.duration - 1.0, 1.37):
                c = np.degrees(rotvec_to_pitch_yaw_roll(
                    m.predict(Audio(au.samples[:int(cut * au.sample_rate)], au.sample_rate), seed=0).rotvec))
                d = np.abs(c[-25:] - full[len(c) - 25:len(c)])
                top = np.linalg.norm(np.diff(c[-26:], axis=0), axis=1).max() * m.model_fps
                rows.append((d.mean(), d.max(), top))
        r = np.array(rows)
        print(f"{mode:8s} {len(r)} cuts: last 0.25 s off the uncut file's by {r[:, 0].mean():.2f}° on average, "
              f"largest {r[:, 1].max():.1f}° (90th percentile of the cuts' largest {np.percentile(r[:, 1], 90):.1f}°); "
              f"top speed there median {np.median(r[:, 2]):.0f} °/s, 90th percentile {np.percentile(r[:, 2], 90):.0f}")
    nets.SYNTHESIS_PAD = keep


if __name__ == "__main__":
    main()
