"""Issue 14's ZEGGS symptom, before and after (docs/tws_realism.md): tws-hier and tws-basic trained
on the whole ZEGGS mocap take and driven by other speech (``../shared/data/speech``, and the take's
own speech with its 2.4 s opening silence).  Prints per system and settings the share of frames
within 1° of the clip limits, the longest stretch within 5° of a clip limit, drift (SD of the 5 s
running mean), and speed in pauses over speed in speech; plots pitch / yaw / roll to
``docs/figures/tws_zeggs_symptom_<file>.png``.  Usage::

    PYTHONPATH=src nice python scripts/tws_zeggs_symptom.py [speech files ...]
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from realism_report import SPEECH, ZEGGS  # noqa: E402

from headmotion.corpus import Corpus, Recording  # noqa: E402
from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.features.vad import _runs  # noqa: E402
from headmotion.io import load_motion  # noqa: E402
from headmotion.io.audio import load_audio  # noqa: E402
from headmotion.rotations import rotvec_to_pitch_yaw_roll  # noqa: E402
from headmotion.systems import create  # noqa: E402

LITERAL = dict(stochastic="none", min_swing_deg=0.0, soft_limit=False, idle=1.0, speed_shaping=False)


def longest_run(mask):
    r = _runs(mask)
    return max((b - a for a, b in r), default=0)


def main():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = [Path(p) for p in sys.argv[1:]] or [SPEECH / "jfk.flac", SPEECH / "chinese_news.wav",
                                                 ZEGGS.with_suffix(".wav")]
    m = load_motion(ZEGGS.with_suffix(".bvh"))
    a = load_audio(ZEGGS.with_suffix(".wav"))
    corpus = Corpus([Recording.aligned("zeggs", "zeggs", "mocap", a, m)])
    models = {}
    for name in ("tws-hier", "tws-basic"):
        for tag, kw in (("before", LITERAL), ("after", {})):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                models[(name, tag)] = create(name, features="f0e", fps=100.0, **kw).fit(corpus)
    print("| speech | system | settings | seed | sat (within 1° of clip) | longest within 5° of clip (s) | "
          "yaw range (°) | drift (°) | pause/speech speed |")
    print("|---|---|---|---|---|---|---|---|---|")
    for f in files:
        au = load_audio(f, sample_rate=16000)
        if au.duration > 40:
            au = au.slice_seconds(0, 40)
        out = {}
        for (name, tag), mdl in models.items():
            lim = mdl.limits_
            span = lim.hi - lim.lo
            lo, hi = lim.lo - 0.1 * span, lim.hi + 0.1 * span
            for seed in ((0,) if tag == "before" else (0, 1)):
                mo = mdl.predict(au, seed=seed)
                rv = np.asarray(mo.rotvec)
                near1 = np.any((rv < lo + np.radians(1)) | (rv > hi - np.radians(1)), axis=1)
                near5 = np.any((rv < lo + np.radians(5)) | (rv > hi - np.radians(5)), axis=1)
                pyr = np.degrees(rotvec_to_pitch_yaw_roll(rv))
                mask = R.speech_mask_for(au, mo)
                row = R.realism(mo, mo, speech_mask=mask)
                print(f"| {f.stem} | {name} | {tag} | {seed} | {near1.mean():.1%} | {longest_run(near5) / mo.fps:.1f} | "
                      f"{pyr[:, 1].min():.0f}…{pyr[:, 1].max():.0f} | {row['drift']:.1f} | {row['pause_ratio']:.2f} |")
                out[(name, tag, seed)] = (pyr, mask, mo.fps)
        fig, axes = plt.subplots(4, 1, figsize=(13, 10), sharex=True)
        for k, name in enumerate(("tws-hier", "tws-basic")):
            for tag, seed, col in (("before", 0, "tab:red"), ("after", 0, "tab:blue"), ("after", 1, "tab:green")):
                pyr, mask, fps = out[(name, tag, seed)]
                t = np.arange(len(pyr)) / fps
                for j in (1, 0):  # yaw, then pitch
                    axes[2 * k + (0 if j == 1 else 1)].plot(t, pyr[:, j], color=col, lw=1,
                                                            label=f"{tag} seed {seed}")
            for ax, ax_name in zip(axes[2 * k:2 * k + 2], ("yaw", "pitch")):
                for s0, s1 in _runs(~mask):
                    ax.axvspan(s0 / fps, s1 / fps, color="0.9", lw=0)
                ax.set_ylabel(f"{name}\n{ax_name} (°)")
        axes[0].legend(fontsize=8, ncol=3, loc="upper right")
        axes[-1].set_xlabel(f"s — {f.name}, trained on the whole ZEGGS take (grey: no speech)")
        fig.tight_layout()
        out_png = Path("docs/figures") / f"tws_zeggs_symptom_{f.stem}.png"
        fig.savefig(out_png, dpi=90)
        plt.close(fig)
        print(f"wrote {out_png}", file=sys.stderr)


if __name__ == "__main__":
    main()
