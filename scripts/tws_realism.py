"""Before / after realism of the template-warping systems (issue 14 phase 2, docs/tws_realism.md).

tws-basic and tws-hier, trained on real data and driven by held-out speech (the splits of
``scripts/realism_report.py``: the talking-video corpus without mead_lrs3 in 2 speaker-disjoint
folds, the ZEGGS take in 4 folds cut at pauses), in named variants of their parameters; every
variant is predicted with seeds 0 and 1 (one row each) and the diversity of the two.  Predictions
are cached under ``--cache`` per (set, system, variant).  Usage::

    PYTHONPATH=src nice python scripts/tws_realism.py [--sets zeggs video] [--systems tws-hier tws-basic]
        [--variants before after] [--csv out.csv]

Variants: ``before`` = the thesis's literal settings (stochastic none, min_swing 0, no soft limit,
no pause settling); ``after`` = the product defaults; more in VARIANTS.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from realism_report import (HOME, at_rate, limits_of, log, print_table, rows_for, speaker_folds, write_rows_csv,  # noqa: E402
                            video_corpus, zeggs_folds)

from headmotion.corpus import Corpus  # noqa: E402
from headmotion.systems import create  # noqa: E402

LITERAL = dict(stochastic="none", min_swing_deg=0.0, soft_limit=False, idle=1.0, speed_shaping=False)
VARIANTS = {
    "before": LITERAL,
    "after": {},
    "after-nosoft": dict(soft_limit=False),
    "after-nopause": dict(idle=1.0),
    "after-h1": dict(min_swing_deg=1.0),
    "after-both": dict(stochastic="both"),
    "after-i0.3": dict(idle=0.3),
    "after-log": dict(log_params=True),
}
SEEDS = (0, 1)


def run(sysname, variant, tag, recs, folds, cache: Path):
    f = cache / f"{tag}_{sysname}_{variant}.npz"
    if f.exists():
        z = np.load(f)
        return {r.id: [z[f"{r.id}_s{s}"] for s in SEEDS] for r in recs}
    out = {}
    t = time.time()
    for k, test in enumerate(folds):
        train = [recs[i] for i in range(len(recs)) if i not in test]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = create(sysname, features="f0e", fps=100.0, **VARIANTS[variant]).fit(Corpus(train))
        for i in test:
            r = recs[i]
            out[r.id] = [at_rate(model.predict(r.audio, seed=s), r.motion.fps, len(r.motion)) for s in SEEDS]
        det = getattr(model, "speech_detector_", None)
        log(f"  {tag} {sysname} {variant} fold {k + 1}/{len(folds)} ({time.time() - t:.0f} s)"
            + (f" speech detector balanced accuracy {det.accuracy:.2f}" if det is not None else ""))
    cache.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(f, **{f"{rid}_s{s}": v[i] for rid, v in out.items() for i, s in enumerate(SEEDS)})
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--corpus", default=str(HOME / "corpus/talking_video"))
    ap.add_argument("--sets", nargs="*", default=["zeggs", "video"])
    ap.add_argument("--systems", nargs="*", default=["tws-hier", "tws-basic"])
    ap.add_argument("--variants", nargs="*", default=["before", "after"])
    ap.add_argument("--cache", default=str(HOME / "tws_realism"))
    ap.add_argument("--csv", default=None)
    ap.add_argument("--shifts", type=int, default=100)
    a = ap.parse_args()
    cache = Path(a.cache)
    ctx: dict = {}
    all_rows = []
    for tag in a.sets:
        if tag == "zeggs":
            recs = zeggs_folds(4)
            folds = [[i] for i in range(len(recs))]
        else:
            recs = [r for r in video_corpus(Path(a.corpus)) if r.motion.duration >= 4.0]
            folds = speaker_folds(recs, 2)
        rows = rows_for("ground-truth", recs, [r.motion for r in recs], ctx, n_shifts=a.shifts)
        rows += rows_for("desync", recs, [np.roll(r.motion.rotvec, len(r.motion) // 2, axis=0) for r in recs], ctx,
                         n_shifts=a.shifts)
        for sysname in a.systems:
            for v in a.variants:
                out = run(sysname, v, tag, recs, folds, cache)
                samples = [out[r.id] for r in recs]
                for i, s in enumerate(SEEDS):
                    rows += rows_for(f"{sysname} {v} s{s}", recs, [out[r.id][i] for r in recs], ctx,
                                     limits=limits_of(recs), samples=samples if i == 0 else None, n_shifts=a.shifts)
        all_rows += [{"set": tag, **r} for r in rows]
        print_table(rows, f"{tag}: held-out speech")
    if a.csv:
        write_rows_csv(all_rows, a.csv)


if __name__ == "__main__":
    main()
