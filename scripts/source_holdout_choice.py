#!/usr/bin/env python
"""Choosing ``motion-match``'s settings on a held-out *source* (docs/decisions/follow-any-voice.md).

The library of every variant is built from the corpus's other sources (without ``--exclude``'s,
e.g. the non-commercial ``mead_lrs3`` clips the shipped models never see); the speech ↔ motion
projections of the cross-speaker coupling are fitted on the recorded heads of every recording not
held out; each variant makes one take per seed of every held-out recording and the takes are
tested against the circular-shift null and pooled over the recordings (mean excess, Stouffer's p),
as ``headmotion evaluate`` pools them.  One line per variant: the seeds' excess (p) and their mean.

    python scripts/source_holdout_choice.py ~/.cache/headmotion/corpus/talking_video --held pc_avs \\
        --seeds 0-7 --variants '{"now": {"prosody": "f0e-live"}, "centred": {"prosody": "f0e-live", "centred": true}}'

``--held`` takes sources joined by ``+`` (``sadtalker+styletalk+video_retalking``: held out together).
The corpus needs a ``source`` column (``scripts/build_real_corpus.py`` writes one).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    from headmotion.cli.speech_eval_cmds import parse_seeds
    from headmotion.corpus import Corpus
    from headmotion.evaluation.measures.cross_coupling import CrossSpeakerCCA, pooled
    from headmotion.evaluation.protocol.folds import source_of
    from headmotion.evaluation.protocol.speech_only import speech_features
    from headmotion.systems.base import create

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("--held", required=True, help="the source(s) held out, joined by +")
    ap.add_argument("--variants", required=True, help="JSON: name → motion-match parameters")
    ap.add_argument("--seeds", default="0-7")
    ap.add_argument("--exclude", default="mead_lrs3", help="sources never in a library (comma-separated)")
    ap.add_argument("--shifts", type=int, default=200)
    a = ap.parse_args(argv)

    held = set(a.held.split("+"))
    never = {s.strip() for s in a.exclude.split(",") if s.strip()}
    corpus = Corpus.load(a.corpus)
    src = [source_of(e) for e in corpus.entries]
    if any(s is None for s in src):
        raise SystemExit(f"{a.corpus}: every recording needs a source (run scripts/build_real_corpus.py again)")
    unknown = held - set(src)
    if unknown:
        raise SystemExit(f"no recordings of source(s) {sorted(unknown)}; the corpus has {sorted(set(src))}")
    library = corpus.subset([i for i, s in enumerate(src) if s not in held and s not in never])
    test = list(corpus.subset([i for i, s in enumerate(src) if s in held]))
    others = list(corpus.subset([i for i, s in enumerate(src) if s not in held]))
    cca = CrossSpeakerCCA().fit([r.motion for r in others], [speech_features(r.audio) for r in others])
    feats = [speech_features(r.audio) for r in test]
    seeds = parse_seeds(a.seeds)

    def test_all(motions):
        res = [cca.test(m, f, n_shifts=a.shifts, seed=i) for i, (m, f) in enumerate(zip(motions, feats))]
        return pooled(res, n_shifts=a.shifts)

    rec = test_all([r.motion for r in test])
    print(f"held out {'+'.join(sorted(held))}: {len(test)} recordings; library {len(library)} recordings; "
          f"recorded heads {rec['excess']:+.3f} (p {rec['p']:.3g})")
    print("| variant | " + " | ".join(f"seed {s}" for s in seeds) + " | mean excess |")
    print("|---|" + "---|" * (len(seeds) + 1))
    for name, params in json.loads(a.variants).items():
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = create("motion-match", **params).fit(library)
        cells, ex = [], []
        for s in seeds:
            p = test_all([model.predict(r.audio, seed=s) for r in test])
            cells.append(f"{p['excess']:+.3f} ({p['p']:.3f})")
            ex.append(p["excess"])
        print(f"| {name} | " + " | ".join(cells) + f" | {np.mean(ex):+.3f} |", flush=True)
        print(f"  ({name}: {time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
