"""Calibration of the FCCA coupling test on uncoupled anchors (docs/decisions/coupling-test.md).

For every evaluation seed, the corpus is dealt into speaker-disjoint folds exactly as
``headmotion evaluate --protocol speakers`` does; the uncoupled anchors (shaped noise, another
speaker's motion; no training) are made for every held-out recording with the evaluation's seeds,
scored by Forced CCA (global and 3 s local) against the recording's speech features with the
circular-shift null of :mod:`headmotion.evaluation.chance` — once with plain circular shifts (the
old test) and once with shifts of the motion's bridge (the new one) — and the per-recording p
values are pooled with Stouffer's Z as the evaluation pools them.  Under the null (the anchors are
uncoupled by construction) the pooled p is uniform: the share below 0.05 should be 0.05.

    python scripts/coupling_calibration.py ~/.cache/headmotion/corpus/talking_video \
        --seeds 40 --shifts 100 --min-seconds 4 --speaker-folds 3 -o .scratch/coupling
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

from headmotion.corpus import Corpus
from headmotion.evaluation import chance as C
from headmotion.evaluation import metrics as M
from headmotion.evaluation.anchors import create_anchor
from headmotion.evaluation.feature_table import extract_one
from headmotion.evaluation.parallel import sub_seed
from headmotion.evaluation.protocols import make_folds
from headmotion.evaluation.realism import stouffer

ANCHOR_NAMES = ("shaped-noise", "other-speaker")
#: (label, null, min_shift): the old test, and each of its two changes alone and together
VARIANTS = (("old: circular, offsets T/4..3T/4", "circular", "quarter"), ("circular, all offsets", "circular", 1),
            ("bridge, offsets T/4..3T/4", "bridge", "quarter"), ("new: bridge, all offsets", "bridge", 1))


def _scores(rec, pred, feats, *, n_shifts: int, window_s: float, seed: int, null: str, min_shift) -> dict:
    x = np.asarray(rec.motion.rotvec, dtype=float)
    n = min(len(x), len(pred), len(feats))
    x, p, f = x[:n], pred[:n], feats[:n]
    w = max(3, min(int(round(window_s * rec.motion.fps)), n))
    xd, pd = np.hstack([x, M.deltas(x)]), np.hstack([p, M.deltas(p)])
    ss = np.random.SeedSequence(seed).generate_state(4)
    quarter = min_shift == "quarter"  # the old default: offsets in [min(window, T // 4), T − that]
    g = C.fcca_null(xd, f, pd, n_shifts=n_shifts, seed=int(ss[2]), null=null,
                    min_shift=n // 4 if quarter else min_shift)
    loc = C.fcca_null(xd, f, pd, window=w, n_shifts=n_shifts, seed=int(ss[3]), null=null,
                      min_shift=min(w, n // 4) if quarter else min_shift)
    return {"fcca_p": g.p_value, "fcca_excess": g.excess, "fcca_local_p": loc.p_value,
            "fcca_local_excess": loc.excess}


def run(corpus: Corpus, seeds, *, n_shifts: int, speaker_folds: int, window_s: float, features: str) -> list[dict]:
    feats = {r.id: np.asarray(M.as_array(extract_one(features, r.audio, fps=float(r.motion.fps),
                                                     n_frames=len(r.motion)))[0]) for r in corpus}
    out = []
    for seed in seeds:
        per = {(a, v[0]): [] for a in ANCHOR_NAMES for v in VARIANTS}
        for _fold, train, test, others in make_folds(corpus, "speakers", seed=seed, speaker_folds=speaker_folds):
            for name in ANCHOR_NAMES:
                anchor = create_anchor(name)
                anchor.fit(others if anchor.needs_other_speakers else train)
                for rec in test:
                    rseed = sub_seed(seed, rec.id, name)
                    pred = np.asarray(anchor.motion_for(rec, seed=rseed).rotvec, dtype=float)
                    for label, null, min_shift in VARIANTS:
                        per[(name, label)].append(_scores(rec, pred, feats[rec.id], n_shifts=n_shifts,
                                                          window_s=window_s, seed=rseed, null=null,
                                                          min_shift=min_shift))
        for (name, null), rows in per.items():
            rec = {"seed": seed, "anchor": name, "null": null, "n": len(rows)}
            for m in ("fcca", "fcca_local"):
                rec[f"{m}_p_pooled"] = stouffer([r[f"{m}_p"] for r in rows], n_shifts=n_shifts)
                rec[f"{m}_excess_pooled"] = float(np.mean([r[f"{m}_excess"] for r in rows]))
                rec[f"{m}_p_records"] = [r[f"{m}_p"] for r in rows]
            out.append(rec)
        print(seed, {f"{k[0]}/{k[1]}": round(stouffer([r["fcca_p"] for r in v], n_shifts=n_shifts), 3)
                     for k, v in per.items()}, flush=True)
    return out


def summary(rows: list[dict]) -> list[dict]:
    table = []
    for name in ANCHOR_NAMES:
        for null, _, _ in VARIANTS:
            sel = [r for r in rows if r["anchor"] == name and r["null"] == null]
            for m in ("fcca", "fcca_local"):
                ps = np.array([r[f"{m}_p_pooled"] for r in sel])
                k = int(np.sum(ps < 0.05))
                ci = binomtest(k, len(ps)).proportion_ci(0.95, method="exact")
                rec_ps = np.concatenate([r[f"{m}_p_records"] for r in sel])
                table.append({"anchor": name, "null": null, "metric": m, "seeds": len(ps), "share_p_lt_0.05": k / len(ps),
                              "ci_low": ci.low, "ci_high": ci.high, "median_p": float(np.median(ps)),
                              "mean_excess": float(np.mean([r[f"{m}_excess_pooled"] for r in sel])),
                              "share_excess_pos": float(np.mean([r[f"{m}_excess_pooled"] > 0 for r in sel])),
                              "records_share_p_lt_0.05": float(np.mean(rec_ps < 0.05)),
                              "records_share_p_gt_0.95": float(np.mean(rec_ps > 0.95))})
    return table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("corpus")
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--shifts", type=int, default=100)
    ap.add_argument("--min-seconds", type=float, default=4.0)
    ap.add_argument("--speaker-folds", type=int, default=3)
    ap.add_argument("--window", type=float, default=3.0)
    ap.add_argument("--features", default="f0e")
    ap.add_argument("-o", "--output", type=Path, required=True)
    a = ap.parse_args()
    corpus = Corpus.load(a.corpus)
    corpus = corpus.subset([i for i, r in enumerate(corpus) if r.duration >= a.min_seconds])
    rows = run(corpus, range(a.seeds), n_shifts=a.shifts, speaker_folds=a.speaker_folds, window_s=a.window,
               features=a.features)
    a.output.mkdir(parents=True, exist_ok=True)
    (a.output / "seeds.json").write_text(json.dumps(rows))
    table = summary(rows)
    (a.output / "summary.json").write_text(json.dumps(table, indent=1))
    print("| anchor | null | metric | seeds | pooled p < 0.05 [95% CI] | median pooled p | mean excess | "
          "recordings p < 0.05 / > 0.95 |")
    print("|---|---|---|---|---|---|---|---|")
    for t in table:
        print(f"| {t['anchor']} | {t['null']} | {t['metric']} | {t['seeds']} | {t['share_p_lt_0.05']:.3f} "
              f"[{t['ci_low']:.3f}, {t['ci_high']:.3f}] | {t['median_p']:.3f} | {t['mean_excess']:+.4f} | "
              f"{t['records_share_p_lt_0.05']:.3f} / {t['records_share_p_gt_0.95']:.3f} |")


if __name__ == "__main__":
    main()
