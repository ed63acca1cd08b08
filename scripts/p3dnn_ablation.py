"""Which part of the DNN systems' causal post stage (issue 16) moves the realism figures of offline
``predict``: the running-mean GV/drift centre or the causal pauses (detector + weight)?

Trains mfcc-dnn once per fold (the folds and training settings of scripts/p2dnn_measure.py), then
synthesises the held-out speech with the product defaults in four ways — {utterance-mean centre,
running-mean centre} × {offline pauses (features.vad.speaking_mask, pause_weight), causal pauses
(the shipped ones)} — and prints one line of realism measures per variant and seed.

    PYTHONPATH=src nice python scripts/p3dnn_ablation.py [zeggs|video] [--seeds 2]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from p2dnn_measure import KEYS, train_kwargs  # noqa: E402
from realism_report import HOME, at_rate, context, limits_of, speaker_folds, video_corpus, zeggs_folds  # noqa: E402

from headmotion.corpus import Corpus  # noqa: E402
from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.features.vad import speaking_mask  # noqa: E402
from headmotion.motion.pauses import settle_in_pauses  # noqa: E402
from headmotion.systems import create, dnn_post  # noqa: E402
from headmotion.types import Motion  # noqa: E402

warnings.filterwarnings("ignore")


class UtteranceMeanPost(dnn_post.CausalPost):
    """The issue-14 centre (the utterance mean), for one push over a whole utterance."""

    def push(self, y):
        y = np.asarray(y, dtype=np.float64)
        if self.identity or len(y) == 0:
            return y
        c = y.mean(axis=0)
        k = np.sqrt(1.0 - self.share) * (np.ones(y.shape[1]) if self.gv is None else self.gv)
        out = c + k * (y - c)
        if self.share > 0:
            out = out + np.sqrt(self.share) * self.sd * dnn_post.ou_process(
                len(y), y.shape[1], fps=100.0, tau_s=4.0, rng=self.rng)
        return out


def synth(model, audio, seed, centre, pauses):
    real = dnn_post.CausalPost
    try:
        if centre == "utt":
            dnn_post.CausalPost = UtteranceMeanPost
        if pauses == "causal":
            model.set_params(idle=0.4)
            return model.predict(audio, seed=seed)
        model.set_params(idle=None)
        m = model.predict(audio, seed=seed)
    finally:
        dnn_post.CausalPost = real
        model.set_params(idle=0.4)
    mask = speaking_mask(audio, fps=100.0, n_frames=len(m))
    rv = settle_in_pauses(m.rotvec, mask, fps=100.0, idle=0.4, mean_pose=np.asarray(model.motion_norm_.mean_))
    return Motion(rv, m.fps)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("set", nargs="?", default="zeggs")
    ap.add_argument("--seeds", type=int, default=2)
    a = ap.parse_args()
    if a.set == "zeggs":
        recs = zeggs_folds(4)
        folds = [[i] for i in range(4)]
    else:
        recs = [r for r in video_corpus(HOME / "corpus/talking_video") if r.duration >= 4]
        folds = speaker_folds(recs, 2)
    variants = [(c, p) for c in ("utt", "running") for p in ("offline", "causal")]
    preds = {}
    for test in folds:
        train = [recs[i] for i in range(len(recs)) if i not in test]
        model = create("mfcc-dnn", **train_kwargs("mfcc-dnn")).fit(Corpus(train))
        for v in variants:
            for i in test:
                for s in range(a.seeds):
                    preds[(v, i, s)] = at_rate(synth(model, recs[i].audio, s, *v), recs[i].motion.fps,
                                               len(recs[i].motion))
    ctx = {}
    masks, ons, feats = zip(*[context(r, ctx) for r in recs])
    lim = limits_of(recs)
    for v in variants:
        for s in range(a.seeds):
            name = f"{v[0]}-centre+{v[1]}-pauses"
            rows = R.realism_rows({name: [preds[(v, i, s)] for i in range(len(recs))]}, [r.motion for r in recs],
                                  speech_masks=masks, onsets=ons, features=feats, limits_deg={name: lim},
                                  n_shifts=100)
            r = rows[-1]
            print(f"{a.set:5s} {name:32s} s{s} " + " ".join(f"{lab}={r.get(k, float('nan')):.3g}" for k, lab in KEYS
                                                           if k not in ("diversity",)), flush=True)


if __name__ == "__main__":
    main()
