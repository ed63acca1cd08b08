"""The ruler's top: how well the detectability test tells recorded speakers from recorded speakers
(docs/decisions/detectability.md).

* ``halves`` — the corpus's speakers dealt at random into two halves (per seed); one half's
  recordings are the "recorded" sample, the other's the "generated" one.
* ``--other DIR`` — every recording of this corpus against every recording of another one (the
  ZEGGS actor against the video speakers).

Usage::

    PYTHONPATH=src python scripts/detectability_speakers.py CORPUS_DIR [--seeds 5] [--other OTHER_DIR]
"""

from __future__ import annotations

import argparse

import numpy as np

from headmotion.corpus import Corpus
from headmotion.evaluation.detection import detectability as D


def _line(label: str, res) -> str:
    cells = [f"{n} BA {s.balanced_accuracy:.2f} [{s.ba_ci[0]:.2f}, {s.ba_ci[1]:.2f}] AUC {s.auc:.2f}"
             for n, s in res.scores.items()]
    top = ", ".join(f"{n} {v:.2f}" for n, v in res.top_statistics(3))
    return f"| {label} | {res.detectability:.2f} | " + " | ".join(cells) + f" | {res.n_real}/{res.n_generated} | {top} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("corpus")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--min-seconds", type=float, default=4.0)
    ap.add_argument("--other", default=None)
    a = ap.parse_args()
    c = Corpus.load(a.corpus)
    recs = [r for r in c if r.duration >= a.min_seconds]
    print("| comparison | detectability | stats | cnn | windows | separates most |\n|---|---|---|---|---|---|")
    dets = []
    for seed in range(a.seeds):
        spk = sorted({r.speaker for r in recs})
        rng = np.random.default_rng(seed)
        rng.shuffle(spk)
        half = set(spk[: len(spk) // 2])
        A = {r.id: r.motion for r in recs if r.speaker in half}
        B = {r.id: r.motion for r in recs if r.speaker not in half}
        res = D.detectability(A, B, seed=seed, chunk_s=12.0)
        dets.append(res.detectability)
        print(_line(f"speakers half A vs half B, seed {seed}", res), flush=True)
    print(f"\nmean over {a.seeds} seeds: {np.mean(dets):.3f} (min {np.min(dets):.3f}, max {np.max(dets):.3f})")
    if a.other:
        o = Corpus.load(a.other)
        res = D.detectability({r.id: r.motion for r in o}, {r.id: r.motion for r in recs}, seed=0, chunk_s=12.0)
        print(_line(f"{a.other} (recorded) vs {a.corpus}", res))


if __name__ == "__main__":
    main()
