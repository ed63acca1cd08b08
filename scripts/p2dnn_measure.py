"""Before/after realism of le2012 and the DNN systems with the issue-14 fixes (phase 2).

Trains each system once per fold (video corpus without mead_lrs3: 2 speaker-disjoint folds;
ZEGGS: 4 folds cut at pauses; the folds of scripts/realism_report.py), then synthesises the
held-out speech with several synthesis-time settings (``set_params`` on the fitted model) and
seeds, and prints one line of realism measures per variant and seed.  Predictions are cached in
``~/.cache/headmotion/p2dnn/`` (delete to recompute).

    PYTHONPATH=src nice python scripts/p2dnn_measure.py mfcc-dnn [video|zeggs|both] [--seeds 2]
    PYTHONPATH=src nice python scripts/p2dnn_measure.py le2012 both
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from realism_report import HOME, at_rate, context, limits_of, speaker_folds, video_corpus, zeggs_folds  # noqa: E402

from headmotion.corpus import Corpus  # noqa: E402
from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.systems import create  # noqa: E402

warnings.filterwarnings("ignore")
KEYS = [("band_1.5_4", "1.5-4"), ("band_1.5_4_ref", "gt"), ("band_0_0.5", "<0.5"), ("spectral_l1", "L1"),
        ("sd_ratio_pitch", "SDp"), ("sd_ratio_yaw", "SDy"), ("sd_ratio_roll", "SDr"), ("speed_hellinger", "Hsp"),
        ("limit_cycle", "LC"), ("limit_cycle_ref", "gt"), ("saturation", "sat"), ("pause_ratio", "pause"),
        ("pause_ratio_ref", "gt"), ("drift", "drift"), ("fcca_excess", "FCCAx"), ("fcca_p_pooled", "p"),
        ("diversity", "div")]
PAPER = {"variance_restore": False, "drift_share": 0.0, "idle": None}
VARIANTS = {
    "mfcc-dnn": {
        "paper": PAPER,
        "gv+p0.4": {"variance_restore": True, "drift_share": 0.0, "idle": 0.4},
        "gv+d0.3+p0.4": {"variance_restore": True, "drift_share": 0.3, "idle": 0.4},
        "gv+d0.4+p0.4": {"variance_restore": True, "drift_share": 0.4, "idle": 0.4},
    },
    "le2012": {
        "paper": {"pull_tau_s": None, "start_sd": 0.0, "idle": None},
        "pull2s": {"pull_tau_s": 2.0, "start_sd": 0.0, "idle": None},
        "pull2s+s0.5+p0.4": {"pull_tau_s": 2.0, "start_sd": 0.5, "idle": 0.4},
        "pull2s+s0.5+p0.7": {"pull_tau_s": 2.0, "start_sd": 0.5, "idle": 0.7},
    },
    # the drift share sweep (4 seeds)
    "mfcc-dnn-share": {f"gv+d{d}+p0.4": {"variance_restore": True, "drift_share": d, "idle": 0.4}
                       for d in (0.1, 0.15, 0.2, 0.25, 0.3)},
    # slower posture drift (time constant 4 / 8 s)
    "mfcc-dnn-tau-share": {f"gv+d{d}+tau{t}+p0.4": {"variance_restore": True, "drift_share": d, "drift_tau_s": t,
                                                     "idle": 0.4}
                           for t in (4.0, 8.0) for d in (0.15, 0.3)},
    # the chosen product default next to the paper
    "mfcc-dnn-final": {"paper": PAPER, "gv+p0.4": {"variance_restore": True, "drift_share": 0.0, "idle": 0.4},
                       "gv+d0.15+tau4.0+p0.4": {"variance_restore": True, "drift_share": 0.15, "drift_tau_s": 4.0,
                                                "idle": 0.4}},
}
VARIANTS["cccae"] = {k: VARIANTS["mfcc-dnn"][k] for k in ("paper", "gv+d0.3+p0.4")}
for s in ("f0e-dnn", "fbank-dnn", "ae-dnn", "wav-dnn"):
    VARIANTS[s] = VARIANTS["cccae"]


def system_of(name):
    return name.split("-final")[0].split("-tau")[0].split("-share")[0]


def train_kwargs(system):
    if system == "le2012":
        return {}
    return {"max_epochs": 15, "ae_max_epochs": 20}


def run(system, tag, recs, folds, variants, seeds, cache, n_div):
    f = cache / f"{tag}_{system}.npz"
    if f.exists():
        z = np.load(f)
        preds = {k: z[k] for k in z.files}
    else:
        preds, t0 = {}, time.time()
        for k, test in enumerate(folds):
            train = [recs[i] for i in range(len(recs)) if i not in test]
            t1 = time.time()
            model = create(system_of(system), **train_kwargs(system)).fit(Corpus(train))
            tfit = time.time() - t1
            for vname, params in variants.items():
                model.set_params(**params)
                for i in test:
                    r = recs[i]
                    for s in range(max(seeds, n_div)):
                        preds[f"{vname}|{r.id}|{s}"] = at_rate(model.predict(r.audio, seed=s), r.motion.fps,
                                                               len(r.motion))
            print(f"  {tag} {system} fold {k + 1}/{len(folds)}: fit {tfit:.0f} s, total {time.time() - t0:.0f} s",
                  flush=True)
        cache.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(f, **preds)
    ctx = {}
    masks, ons, feats = zip(*[context(r, ctx) for r in recs])
    lim = limits_of(recs)
    out = []
    for vname in variants:
        for s in range(seeds):
            cands = [preds[f"{vname}|{r.id}|{s}"] for r in recs]
            samples = None
            if s == 0 and n_div >= 2:
                samples = {vname: [[preds[f"{vname}|{r.id}|{k}"] for k in range(n_div)] for r in recs]}
            rows = R.realism_rows({vname: cands}, [r.motion for r in recs], speech_masks=masks, onsets=ons,
                                  features=feats, limits_deg={vname: lim}, samples=samples, n_shifts=100)
            a = rows[-1]
            line = {"set": tag, "system": system, "variant": vname, "seed": s,
                    **{k: a.get(k, float("nan")) for k, _ in KEYS}}
            out.append(line)
            print(f"{tag:5s} {system:8s} {vname:18s} s{s} " + " ".join(
                f"{lab}={line[k]:.3g}" for k, lab in KEYS), flush=True)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("system")
    ap.add_argument("sets", nargs="?", default="both")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--div", type=int, default=4, help="samples for diversity (seed 0 row)")
    ap.add_argument("--cache", default=str(HOME / "p2dnn"))
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    cache = Path(a.cache)
    variants = VARIANTS[a.system]
    out = []
    if a.sets in ("video", "both"):
        v = [r for r in video_corpus(HOME / "corpus/talking_video") if r.duration >= 4]
        out += run(a.system, "video", v, speaker_folds(v, 2), variants, a.seeds, cache, a.div)
    if a.sets in ("zeggs", "both"):
        z = zeggs_folds(4)
        out += run(a.system, "zeggs", z, [[i] for i in range(4)], variants, a.seeds, cache, a.div)
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    main()
