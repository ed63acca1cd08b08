"""Detectability of today's systems and anchors on a corpus (docs/decisions/detectability.md).

Runs ``headmotion evaluate``'s cross-validation (its detectability hook included) with the
systems retrained per fold, the anchors, and — as conditions that are not retrained — the shipped
default and streaming models applied to every held-out recording's speech (on the talking-video
corpus they were trained on it: in-sample).  Writes the usual report directory (metrics.csv,
report.md with the detectability table, figures/detect_*.png).  Usage::

    PYTHONPATH=src python scripts/detectability_measure.py CORPUS_DIR -o OUT [--speaker-folds 3]
        [--folds-at-pauses 4] [--systems mfcc-dnn,tws-hier] [--seed 0]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from headmotion.align import fit_length
from headmotion.corpus import Corpus
from headmotion.evaluation.protocol.anchors import Anchor
from headmotion.evaluation.protocol.protocols import evaluate
from headmotion.evaluation.reporting.report import write_report

DATA = Path(__file__).resolve().parents[1] / "src" / "headmotion" / "data"


class Shipped(Anchor):
    """A saved model applied to the recording's speech (no training: ``fit`` only stores the refs)."""

    def __init__(self, path: Path, name: str):
        self.path, self.label = Path(path), name

    def _after_fit(self):
        from headmotion.systems.base import load_model

        self.model_ = load_model(self.path)

    def _rotvec_for(self, recording, seed):
        m = self.model_.predict(recording.audio, seed=seed)
        if abs(m.fps - recording.motion.fps) > 1e-9:
            m = m.resample(recording.motion.fps)
        return np.asarray(fit_length(np.asarray(m.rotvec), len(recording.motion)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("corpus")
    ap.add_argument("-o", "--output", type=Path, required=True)
    ap.add_argument("--speaker-folds", type=int, default=3)
    ap.add_argument("--folds-at-pauses", type=int, default=0)
    ap.add_argument("--min-seconds", type=float, default=4.0)
    ap.add_argument("--systems", default="mfcc-dnn,tws-hier")
    ap.add_argument("--anchors", default="desync,other-speaker,shaped-noise,still")
    ap.add_argument("--no-shipped", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--shifts", type=int, default=100)
    a = ap.parse_args()
    corpus = Corpus.load(a.corpus)
    if a.folds_at_pauses:
        from headmotion.evaluation.protocol.pause_folds import split_corpus_at_pauses

        corpus, _ = split_corpus_at_pauses(corpus, a.folds_at_pauses)
        protocol, folds = "loo", 0
    else:
        corpus = corpus.subset([i for i, r in enumerate(corpus) if r.duration >= a.min_seconds])
        protocol, folds = "speakers", a.speaker_folds
    systems: list = [s for s in (a.systems + "," + a.anchors).split(",") if s]
    if not a.no_shipped:
        systems += [("shipped-default", lambda: Shipped(DATA / "default_model.hmz", "shipped-default")),
                    ("shipped-stream", lambda: Shipped(DATA / "default_stream_model.hmz", "shipped-stream"))]
    res = evaluate(corpus, systems, protocol=protocol, speaker_folds=folds, seed=a.seed, n_shifts=a.shifts,
                   feature_sets=[], fig48=False, samples=1)
    out = write_report(res, a.output, title=f"detectability on {a.corpus}", save_motions=True)
    print(out["report"])
    print(f"detectability: {res.timings.get('detectability', float('nan')):.0f} s; total {res.timings['total_wall']:.0f} s")


if __name__ == "__main__":
    main()
