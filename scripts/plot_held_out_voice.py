#!/usr/bin/env python
"""A held-out source's recording beside what motion-match makes of its speech
(docs/decisions/follow-any-voice.md).

Two settings of ``motion-match`` are built from every other source of the corpus (never the
non-commercial ``mead_lrs3`` clips) and synthesise the recording's speech (seed 0); the figure
stacks the speech (waveform and frame energy), its F0 (Praat's whole-file track and the voiced
frames of the frame-by-frame YIN at the two voicing limits) and the head's pitch, yaw and roll:
recorded, and each setting's (each centred on its own mean); pauses are shaded.

    python scripts/plot_held_out_voice.py ~/.cache/headmotion/corpus/talking_video \\
        pc_avs_Pose_Source_741400163 -o docs/figures/follow_any_voice.png
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

FPS = 25.0
SETTINGS = {
    "before (f0e-live, causal)": {"prosody": "f0e-live", "wait_s": 2},
    "after (centred, voicing 0.45)": {"prosody": "f0e-live", "wait_s": 2, "centred": True, "voicing_threshold": 0.45,
                                      "ease_in": 0.3, "repeat_cost": 1.0},
}


def main(argv=None) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from headmotion.align import n_frames
    from headmotion.corpus import Corpus
    from headmotion.evaluation.protocol.folds import source_of
    from headmotion.features import extract
    from headmotion.features.prosody import praat_pitch
    from headmotion.rotations import rotvec_to_pitch_yaw_roll
    from headmotion.systems.base import create

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("recording")
    ap.add_argument("-o", "--out", type=Path, required=True)
    ap.add_argument("--settings", default=None, help="JSON: label → motion-match parameters (default: before/after)")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    settings = json.loads(a.settings) if a.settings else SETTINGS
    corpus = Corpus.load(a.corpus)
    i = corpus.ids.index(a.recording)
    held = source_of(corpus.entries[i])
    lib = corpus.subset([k for k, e in enumerate(corpus.entries) if source_of(e) not in (held, "mead_lrs3")])
    rec = corpus[i]
    audio = rec.audio
    n = n_frames(len(audio.samples), audio.sample_rate, FPS)
    t = np.arange(n) / FPS
    motions = {"recorded head": rec.motion if abs(rec.motion.fps - FPS) < 1e-9 else rec.motion.resample(FPS)}
    for label, params in settings.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            motions[label] = create("motion-match", **params).fit(lib).predict(audio, seed=a.seed)
    f0, voiced = praat_pitch(audio, fps=FPS, n_frames=n)
    yin = {vt: extract("f0e-live", audio, fps=FPS, n_frames=n, voicing_threshold=vt, voicing=True,
                       smooth_lookahead=0, delta_lookahead=0).select(("logf0", "energy", "voiced")).values
           for vt in (0.35, 0.45)}

    fig, ax = plt.subplots(5, 1, figsize=(10, 9), sharex=True)
    x = np.asarray(audio.samples, dtype=float)
    ax[0].plot(np.arange(len(x)) / audio.sample_rate, x, lw=0.3, color="0.6")
    e = ax[0].twinx()
    e.plot(t, yin[0.35][:, 1], color="tab:red", lw=1)
    e.set_ylabel("energy (dB FS)", color="tab:red")
    ax[0].set_ylabel("speech")
    ax[1].plot(t, np.where(voiced, f0, np.nan), color="k", lw=2, label="Praat (voiced)")
    for vt, c in ((0.35, "tab:orange"), (0.45, "tab:green")):
        v = yin[vt][:, 2] > 0.5
        ax[1].plot(t, np.where(v, np.exp(yin[vt][:, 0]), np.nan), ".", ms=3, color=c, label=f"YIN voiced, limit {vt}")
    ax[1].set_ylabel("F0 (Hz)")
    if voiced.any():
        lo, hi = np.percentile(f0[voiced], [1, 99])
        ax[1].set_ylim(0.8 * lo, 1.25 * hi)
    # pauses (no voiced frame within ±0.16 s): shaded on every panel
    near = np.convolve(voiced.astype(float), np.ones(9), mode="same") > 0
    edges = np.flatnonzero(np.diff(np.r_[0, (~near).astype(int), 0]))
    for a0, a1 in zip(edges[::2], edges[1::2]):
        for axis in ax:
            axis.axvspan(a0 / FPS, a1 / FPS, color="0.92", zorder=0)
    ax[1].legend(fontsize=7, loc="upper right")
    colours = ["k", "tab:orange", "tab:green", "tab:blue", "tab:purple"]
    for label, c in zip(motions, colours):
        m = motions[label]
        pyr = np.degrees(np.asarray(rotvec_to_pitch_yaw_roll(m.rotvec)))[:n]
        pyr = pyr - pyr.mean(axis=0)
        tt = np.arange(len(pyr)) / m.fps
        for k, name in enumerate(("pitch", "yaw", "roll")):
            ax[2 + k].plot(tt, pyr[:, k], color=c, lw=2 if label == "recorded head" else 1.2, label=label)
            ax[2 + k].set_ylabel(f"{name} (°, centred)")
    ax[2].legend(fontsize=7, loc="upper right")
    ax[-1].set_xlabel("s")
    fig.suptitle(f"{a.recording} (source {held} held out of the library), seed {a.seed}", fontsize=10)
    fig.tight_layout()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(a.out, dpi=80)
    print("wrote", a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
