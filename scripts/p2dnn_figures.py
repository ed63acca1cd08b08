"""Before/after time series of le2012 and mfcc-dnn on held-out speech (issue 14 phase 2), from
the prediction caches of scripts/p2dnn_measure.py.

    PYTHONPATH=src python scripts/p2dnn_figures.py [--out docs/figures]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from realism_report import HOME, video_corpus, zeggs_folds  # noqa: E402

from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.rotations import rotvec_to_pitch_yaw_roll  # noqa: E402

ROWS = [("mfcc-dnn-final", "paper", "mfcc-dnn, paper (before)"),
        ("mfcc-dnn-final", "gv+d0.15+tau4.0+p0.4", "mfcc-dnn, default: GV + drift 0.15 (4 s) + pauses 0.4"),
        ("le2012", "paper", "le2012, literal (before)"), ("le2012", "pull2s+s0.5+p0.4", "le2012, pull 2 s + seeded start 0.5 + pauses 0.4")]


def figure(tag, rec, out, seconds=20.0):
    f = rec.motion.fps
    n = min(len(rec.motion), int(seconds * f))
    t = np.arange(n) / f
    mask = R.speech_mask_for(rec.audio, rec.motion)[:n]
    fig, axes = plt.subplots(3, 1, figsize=(13, 8), sharex=True)
    gt = np.degrees(rotvec_to_pitch_yaw_roll(rec.motion.rotvec[:n]))
    series = [("recording", gt, "k", 2.0)]
    colours = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
    for (system, variant, label), c in zip(ROWS, colours):
        z = HOME / f"p2dnn/{tag}_{system}.npz"
        if not z.exists():
            continue
        key = f"{variant}|{rec.id}|0"
        d = np.load(z)
        if key in d.files:
            series.append((label, np.degrees(rotvec_to_pitch_yaw_roll(d[key][:n])), c, 1.0))
    for j, ax in enumerate(axes):
        for a, b in R_runs(~mask):
            ax.axvspan(a / f, b / f, color="0.9", lw=0)
        for label, y, c, lw in series:
            ax.plot(t, y[:, j] - y[:, j].mean() * 0, color=c, lw=lw, label=label if j == 0 else None)
        ax.set_ylabel(["pitch (°)", "yaw (°)", "roll (°)"][j])
    axes[0].legend(loc="upper right", fontsize=8, ncol=3)
    axes[-1].set_xlabel(f"time (s) — {rec.id}, held out; grey = no speech")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    print(out)


def R_runs(mask):
    from headmotion.features.vad import _runs

    return _runs(mask)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs/figures")
    a = ap.parse_args()
    out = Path(a.out)
    z = zeggs_folds(4)
    figure("zeggs", z[0], out / "p2dnn_before_after_zeggs.png")
    v = [r for r in video_corpus(HOME / "corpus/talking_video") if r.duration >= 4]
    v = sorted(v, key=lambda r: -r.duration)
    figure("video", v[0], out / "p2dnn_before_after_video.png")


if __name__ == "__main__":
    main()
