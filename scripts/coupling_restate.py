"""Pooled speech coupling of every condition of a ``headmotion evaluate`` report, with the old
coupling test (plain circular shifts over the middle of the circle) beside the new one (shifts of
the motion's bridge over every offset) on the very same motions (docs/decisions/coupling-test.md).

The report must have been written with ``--save-motions`` (motions/CONDITION/RECORDING.npz).
Usage::

    PYTHONPATH=src python scripts/coupling_restate.py REPORT_DIR CORPUS_DIR [--shifts 100] [--seed 0]
        [--folds-at-pauses 4]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from headmotion.corpus import Corpus
from headmotion.evaluation.measures import chance as C
from headmotion.evaluation.measures import metrics as M
from headmotion.evaluation.protocol.feature_table import extract_one
from headmotion.evaluation.protocol.parallel import sub_seed
from headmotion.evaluation.measures.realism import stouffer
from headmotion.io.native import load_npz


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report")
    ap.add_argument("corpus")
    ap.add_argument("--shifts", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--window", type=float, default=3.0)
    ap.add_argument("--folds-at-pauses", type=int, default=0)
    a = ap.parse_args()
    corpus = Corpus.load(a.corpus)
    if a.folds_at_pauses:
        from headmotion.evaluation.protocol.pause_folds import split_corpus_at_pauses

        corpus, _ = split_corpus_at_pauses(corpus, a.folds_at_pauses)
    recs = {r.id: r for r in corpus}
    mdir = Path(a.report) / "motions"
    print("| condition | n | old: FCCA excess, p | new: FCCA excess, p | old: local excess, p | new: local excess, p |")
    print("|---|---|---|---|---|---|")
    feats = {}
    for cdir in sorted(p for p in mdir.iterdir() if p.is_dir()):
        per = {k: [] for k in ("circular", "bridge")}
        for f in sorted(cdir.glob("*.npz")):
            rec = recs.get(f.stem)
            if rec is None:
                continue
            if rec.id not in feats:
                feats[rec.id] = np.asarray(M.as_array(extract_one("f0e", rec.audio, fps=float(rec.motion.fps),
                                                                  n_frames=len(rec.motion)))[0])
            x = np.asarray(rec.motion.rotvec, float)
            p = np.asarray(load_npz(f).rotvec, float)
            fe = feats[rec.id]
            n = min(len(x), len(p), len(fe))
            x, p, fe = x[:n], p[:n], fe[:n]
            xd, pd = np.hstack([x, M.deltas(x)]), np.hstack([p, M.deltas(p)])
            w = max(3, min(int(round(a.window * rec.motion.fps)), n))
            ss = np.random.SeedSequence(sub_seed(a.seed, rec.id, cdir.name)).generate_state(4)
            for null in per:
                g = C.fcca_null(xd, fe, pd, n_shifts=a.shifts, seed=int(ss[2]), null=null)
                loc = C.fcca_null(xd, fe, pd, window=w, n_shifts=a.shifts, seed=int(ss[3]), null=null)
                per[null].append((g.excess, g.p_value, loc.excess, loc.p_value))
        if not per["bridge"]:
            continue
        cells = []
        for j in (0, 2):
            for null in ("circular", "bridge"):
                v = np.array(per[null])
                cells.append(f"{np.mean(v[:, j]):+.3f}, {stouffer(v[:, j + 1], n_shifts=a.shifts):.2g}")
        print(f"| {cdir.name} | {len(per['bridge'])} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
