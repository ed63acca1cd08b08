"""Calibration of the coupling tests on uncoupled anchors (docs/decisions/coupling-test.md,
docs/decisions/cross-speaker-coupling.md).

For every evaluation seed, the corpus is dealt into speaker-disjoint folds exactly as
``headmotion evaluate --protocol speakers`` does; the uncoupled anchors (shaped noise, another
speaker's motion; no training) are made for every held-out recording with the evaluation's seeds,
scored by Forced CCA (global and 3 s local) against the recording's speech features with the
circular-shift null of :mod:`headmotion.evaluation.measures.chance` — once with plain circular shifts (the
old test) and once with shifts of the motion's bridge (the new one) — and the per-recording p
values are pooled with Stouffer's Z as the evaluation pools them.  Under the null (the anchors are
uncoupled by construction) the pooled p is uniform: the share below 0.05 should be 0.05.

``--measures`` picks the tests: ``fcca`` (the four nulls above), ``xcca`` (cross-speaker coupling,
:mod:`headmotion.evaluation.measures.cross_coupling`: projections fitted on each fold's training recordings'
recorded heads and speech, as ``headmotion evaluate`` fits them) and ``bc`` (beat alignment: BC of
the head's angular speed against the speech onsets), the last two with the evaluation's test (the
bridge shifted by every offset) and its per-recording seeds.  ``--anchors`` adds ``floor`` (stretches
of the training folds' recorded heads, never used twice) to the two default anchors.

    python scripts/coupling_calibration.py ~/.cache/headmotion/corpus/talking_video \
        --seeds 40 --shifts 100 --min-seconds 4 --speaker-folds 3 -o .scratch/coupling
    python scripts/coupling_calibration.py ~/.cache/headmotion/corpus/talking_video --exclude mead_lrs3 \
        --seeds 20 --shifts 100 --min-seconds 4 --speaker-folds 3 --measures xcca,bc \
        --anchors shaped-noise,other-speaker,floor -o .scratch/xcca_calibration
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

from headmotion.corpus import Corpus
from headmotion.evaluation.measures import chance as C
from headmotion.evaluation.measures import metrics as M
from headmotion.evaluation.measures import realism as R
from headmotion.evaluation.protocol.anchors import create_anchor
from headmotion.evaluation.measures.cross_coupling import CrossSpeakerCCA
from headmotion.evaluation.protocol.feature_table import extract_one
from headmotion.evaluation.protocol.parallel import sub_seed
from headmotion.evaluation.protocol.protocols import make_folds
from headmotion.evaluation.measures.realism import stouffer

ANCHOR_NAMES = ("shaped-noise", "other-speaker")
MEASURES = ("fcca", "xcca", "bc")
#: the label of the evaluation's test (bridge shifted by every offset) in the tables
NEW = "new: bridge, all offsets"
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


def _new_scores(rec, pred, feats, onsets, model, *, n_shifts: int, seed: int, name: str, measures) -> dict:
    """Cross-speaker coupling and beat alignment of one anchor motion, with the seeds
    ``headmotion evaluate`` gives them (:func:`headmotion.evaluation.protocol.scoring.cross_speaker_coupling`,
    :func:`~headmotion.evaluation.protocol.scoring.beat_alignment`)."""
    out = {}
    fps = float(rec.motion.fps)
    if "xcca" in measures and model is not None:
        r = model.test(pred, feats, fps=fps, n_shifts=n_shifts, seed=sub_seed(sub_seed(seed, rec.id, name), "xcca"))
        out.update({"xcca_p": r.p_value, "xcca_excess": r.excess})
    if "bc" in measures and onsets is not None and len(onsets):
        r = C.shift_null(lambda a: R.beat_consistency(R.motion_beats(a, fps=fps), onsets), pred, n_shifts=n_shifts,
                         seed=sub_seed(sub_seed(seed, rec.id, name), "bc"))
        out.update({"bc_p": r.p_value, "bc_excess": r.excess})
    return out


def run(corpus: Corpus, seeds, *, n_shifts: int, speaker_folds: int, window_s: float, features: str,
        measures=MEASURES, anchors=ANCHOR_NAMES) -> list[dict]:
    feats = {r.id: np.asarray(M.as_array(extract_one(features, r.audio, fps=float(r.motion.fps),
                                                     n_frames=len(r.motion)))[0]) for r in corpus}
    onsets = {r.id: R.speech_onsets(r.audio) for r in corpus} if "bc" in measures else {}
    variants = VARIANTS if "fcca" in measures else ()
    labels = [v[0] for v in variants] + ([NEW] if set(measures) - {"fcca"} and NEW not in [v[0] for v in variants]
                                         else [])
    out = []
    for seed in seeds:
        per = {(a, lab): [] for a in anchors for lab in labels}
        for fold, train, test, others in make_folds(corpus, "speakers", seed=seed, speaker_folds=speaker_folds):
            model = None
            if "xcca" in measures:
                model = CrossSpeakerCCA().fit([r.motion for r in others], [feats[r.id] for r in others],
                                              fps=[float(r.motion.fps) for r in others])
            for name in anchors:
                anchor = create_anchor(name, sub_seed(seed, fold, name))
                anchor.fit(others if anchor.needs_other_speakers else train)
                for rec in test:
                    rseed = sub_seed(seed, rec.id, name)
                    pred = np.asarray(anchor.motion_for(rec, seed=rseed).rotvec, dtype=float)
                    for label, null, min_shift in variants:
                        per[(name, label)].append(_scores(rec, pred, feats[rec.id], n_shifts=n_shifts,
                                                          window_s=window_s, seed=rseed, null=null,
                                                          min_shift=min_shift))
                    if NEW in labels:
                        extra = _new_scores(rec, pred, feats[rec.id], onsets.get(rec.id), model, n_shifts=n_shifts,
                                            seed=seed, name=name, measures=measures)
                        if variants:
                            per[(name, NEW)][-1].update(extra)
                        else:
                            per[(name, NEW)].append(extra)
        for (name, null), rows in per.items():
            rec = {"seed": seed, "anchor": name, "null": null, "n": len(rows)}
            for m in ("fcca", "fcca_local", "xcca", "bc"):
                ps = [r[f"{m}_p"] for r in rows if f"{m}_p" in r]
                if not ps:
                    continue
                rec[f"{m}_p_pooled"] = stouffer(ps, n_shifts=n_shifts)
                rec[f"{m}_excess_pooled"] = float(np.mean([r[f"{m}_excess"] for r in rows if f"{m}_excess" in r]))
                rec[f"{m}_p_records"] = ps
            out.append(rec)
        print(seed, {f"{r['anchor']}/{m}": round(r[f"{m}_p_pooled"], 3) for r in out if r["seed"] == seed
                     and r["null"] == labels[-1] for m in ("fcca", "xcca", "bc") if f"{m}_p_pooled" in r},
              flush=True)
    return out


def summary(rows: list[dict]) -> list[dict]:
    table = []
    for name in dict.fromkeys(r["anchor"] for r in rows):
        for null in dict.fromkeys(r["null"] for r in rows):
            for m in ("fcca", "fcca_local", "xcca", "bc"):
                sel = [r for r in rows if r["anchor"] == name and r["null"] == null and f"{m}_p_pooled" in r]
                if not sel:
                    continue
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
    ap.add_argument("--measures", default=",".join(MEASURES), help=f"comma-separated subset of {MEASURES}")
    ap.add_argument("--anchors", default=",".join(ANCHOR_NAMES),
                    help="comma-separated uncoupled anchors (shaped-noise, other-speaker, floor, …)")
    ap.add_argument("--exclude", default="", help="comma-separated recording-id prefixes to leave out (mead_lrs3)")
    ap.add_argument("-o", "--output", type=Path, required=True)
    a = ap.parse_args()
    measures = tuple(m.strip() for m in a.measures.split(",") if m.strip())
    if not measures or set(measures) - set(MEASURES):
        ap.error(f"--measures must be a subset of {MEASURES}; got {a.measures!r}")
    corpus = Corpus.load(a.corpus)
    prefixes = tuple(p.strip() for p in a.exclude.split(",") if p.strip())
    corpus = corpus.subset([i for i, r in enumerate(corpus) if r.duration >= a.min_seconds
                            and not (prefixes and r.id.startswith(prefixes))])
    rows = run(corpus, range(a.seeds), n_shifts=a.shifts, speaker_folds=a.speaker_folds, window_s=a.window,
               features=a.features, measures=measures, anchors=tuple(x.strip() for x in a.anchors.split(",") if x.strip()))
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
