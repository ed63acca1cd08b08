"""Before / after time series of tws-hier and tws-basic on held-out speech (docs/tws_realism.md):
the recorded head next to each system with the thesis's literal settings and with the product
defaults (seed 0), from the caches of ``scripts/tws_realism.py``.  Usage::

    PYTHONPATH=src python scripts/tws_timeseries_figure.py video dfrf_french
    PYTHONPATH=src python scripts/tws_timeseries_figure.py zeggs zeggs_f0
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from realism_report import HOME, video_corpus, zeggs_folds  # noqa: E402

from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.features.vad import _runs  # noqa: E402


def main():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tag, rid = sys.argv[1], sys.argv[2]
    recs = zeggs_folds(4) if tag == "zeggs" else video_corpus(HOME / "corpus/talking_video")
    rec = [r for r in recs if r.id == rid][0]
    f = rec.motion.fps
    n = min(len(rec.motion), int(20 * f))
    mask = R.speech_mask_for(rec.audio, rec.motion)
    t = np.arange(n) / f
    cache = HOME / "tws_realism"
    fig, axes = plt.subplots(3, 2, figsize=(15, 8), sharex=True)
    for col, sysname in enumerate(("tws-hier", "tws-basic")):
        pred = {v: np.load(cache / f"{tag}_{sysname}_{v}.npz")[f"{rid}_s0"] for v in ("before", "after")}
        for j in range(3):
            ax = axes[j, col]
            for a, b in _runs(~mask[:n]):
                ax.axvspan(a / f, b / f, color="0.92", lw=0)
            gt = np.degrees(rec.motion.rotvec[:, j])
            ax.plot(t, gt[:n] - gt.mean(), "k", lw=2, label="recorded head")
            for v, c in (("before", "tab:red"), ("after", "tab:blue")):
                y = np.degrees(pred[v][:, j])
                ax.plot(t, y[:n] - y.mean(), color=c, lw=1, label=f"{sysname} {v}")
            ax.set_ylabel(["pitch", "yaw", "roll"][j] + " (°)")
        axes[0, col].legend(fontsize=8, loc="upper right")
        axes[-1, col].set_xlabel(f"s ({rid}, held out; grey = no speech)")
    fig.suptitle("before = thesis literal (stochastic none, min swing 0, no soft limit, no settling); "
                 "after = product defaults, seed 0", fontsize=10)
    fig.tight_layout()
    out = Path("docs/figures") / f"tws_before_after_{tag}_{rid}.png"
    fig.savefig(out, dpi=90)
    print("wrote", out)


if __name__ == "__main__":
    main()
