"""Look at the default model's slow-band correction (issue 14, fifth session): the shipped default on
unseen speech with ``slow_band_gain`` 1.0 (fourth session) and 1.15 (product), seed 0, beside a
recorded head of the video corpus on the same scale, and the mean band shares of the default on all
of ``../shared/data/speech`` against the corpus's recorded heads.

    PYTHONPATH=src python scripts/diagnosis_i14/slow_band_figure.py [-o docs/figures/s5_slow_band.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
SPEECH = ROOT.parent / "shared/data/speech"


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from headmotion.cli.synth_cmds import default_model_path
    from headmotion.corpus import Corpus
    from headmotion.evaluation import realism as R
    from headmotion.io.audio import load_audio
    from headmotion.systems import load_model

    ap = argparse.ArgumentParser()
    ap.add_argument("-o", "--output", type=Path, default=ROOT / "docs/figures/s5_slow_band.png")
    ap.add_argument("--file", default="jfk.flac")
    ap.add_argument("--recorded", default="sadtalker_RD_Radio34_000")
    a = ap.parse_args()
    model = load_model(default_model_path())
    gains = (1.0, 1.15)
    files = sorted(p for p in SPEECH.iterdir() if p.stem != "video_retalking_1")
    out = {g: {} for g in gains}
    for g in gains:
        model.set_params(slow_band_gain=g)
        for p in files:
            out[g][p.name] = model.predict(load_audio(p), seed=0)
    corpus = Corpus.load(Path.home() / ".cache/headmotion/corpus/talking_video")
    recs = [r for r in corpus if not r.id.startswith("mead_lrs3") and r.duration >= 4.0]
    rec = next(r for r in recs if r.id == a.recorded)

    fig, axes = plt.subplots(4, 1, figsize=(11, 10))
    deg = 180 / np.pi
    for j, name in enumerate(("pitch", "yaw", "roll")):
        ax = axes[j]
        for g, c in zip(gains, ("tab:gray", "tab:blue")):
            m = out[g][a.file]
            t = np.arange(len(m)) / m.fps
            ax.plot(t, np.asarray(m.rotvec)[:, j] * deg, color=c, lw=1.2,
                    label=f"default, slow_band_gain {g:g} ({a.file})")
        t = np.arange(len(rec.motion)) / rec.motion.fps
        x = np.asarray(rec.motion.rotvec)[:, j] * deg
        ax.plot(t, x - x.mean(), color="tab:orange", lw=1.0, alpha=0.8, label=f"recorded head ({rec.id}, own speech, mean removed)")
        ax.set_ylabel(f"{name} (°)")
        if j == 0:
            ax.legend(fontsize=8, loc="upper right")
    ax = axes[3]
    shares = {f"default ×{g:g}": np.mean([R.band_shares(m) for m in out[g].values()], axis=0) for g in gains}
    shares["recorded heads (video corpus)"] = np.mean([R.band_shares(r.motion) for r in recs], axis=0)
    w = 0.27
    for k, (lab, s) in enumerate(shares.items()):
        ax.bar(np.arange(4) + (k - 1) * w, s, w, label=lab)
    ax.set_xticks(range(4), [f"{lo:g}–{hi:g} Hz" for lo, hi in R.BANDS])
    ax.set_ylabel("mean share of power")
    ax.legend(fontsize=8)
    ax.set_title(f"mean band shares: default on {len(files)} unseen speech files vs {len(recs)} recorded heads", fontsize=9)
    axes[0].set_title("default model on unseen speech: slow band's gain ×1.0 (before) and ×1.15 (now)")
    fig.tight_layout()
    fig.savefig(a.output, dpi=90)
    for lab, s in shares.items():
        print(f"{lab:34s} " + " ".join(f"{x:.3f}" for x in s))
    for g in gains:
        sd = np.median([np.asarray(m.rotvec).std(axis=0) * deg for m in out[g].values()], axis=0)
        print(f"default x{g:g}: median SD p/y/r {sd.round(2)}")
    print("wrote", a.output)


if __name__ == "__main__":
    main()
