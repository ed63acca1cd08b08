#!/usr/bin/env python
"""Choosing ``motion-match``'s settings on a held-out *source* (docs/decisions/follow-any-voice.md).

The library of every variant is built from the corpus's other sources (without ``--exclude``'s,
e.g. the non-commercial ``mead_lrs3`` clips the shipped models never see); the speech ↔ motion
projections of the cross-speaker coupling are fitted on the recorded heads of every recording not
held out, once per speech side (``--sides``: ``praat``, Praat's f0e, the measure as before; ``own``,
the frame-by-frame f0e-live reading; ``energy``, no pitch); each variant makes one take per seed of
every held-out recording and the takes are tested against the circular-shift null and pooled over
the recordings (mean excess, Stouffer's p), as ``headmotion evaluate`` pools them.  One line per
variant and side: the seeds' excess (p), their mean and, with a level, the ratio of the mean to
the level's; the held-out source's recorded heads are the other level.

``--level`` adds, after the variants, the Praat-read twin of each variant (the same settings with
``prosody=f0e``, ``live`` off; docs/decisions/rulers-with-a-level.md) and divides each variant's
mean by its twin's; ``--level NAME`` adds only the twin of variant NAME and divides every
variant by it.

    python scripts/source_holdout_choice.py ~/.cache/headmotion/corpus/talking_video --held pc_avs \\
        --seeds 0-7 --level --variants '{"now": {"prosody": "f0e-live"}, "centred": {"prosody": "f0e-live", "centred": true}}'

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
    from headmotion.errors import ParameterError
    from headmotion.evaluation.measures.cross_coupling import pooled
    from headmotion.evaluation.measures.speech_sides import parse_sides
    from headmotion.evaluation.protocol.folds import source_of
    from headmotion.evaluation.protocol.levels import level_variants, ratio
    from headmotion.evaluation.protocol.speech_only import fit_side_projections, speech_features
    from headmotion.systems.base import create

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("--held", required=True, help="the source(s) held out, joined by +")
    ap.add_argument("--variants", required=True, help="JSON: name → motion-match parameters")
    ap.add_argument("--seeds", default="0-7")
    ap.add_argument("--exclude", default="mead_lrs3", help="sources never in a library (comma-separated)")
    ap.add_argument("--shifts", type=int, default=200)
    ap.add_argument("--sides", default="all", help="speech sides of the coupling: praat, own, energy or all")
    ap.add_argument("--level", nargs="?", const="each", default=None,
                    help="add the Praat-read twin of every variant (or of the variant named) as the level")
    a = ap.parse_args(argv)

    held = set(a.held.split("+"))
    never = {s.strip() for s in a.exclude.split(",") if s.strip()}
    sides = parse_sides(a.sides)
    corpus = Corpus.load(a.corpus)
    src = [source_of(e) for e in corpus.entries]
    if any(s is None for s in src):
        raise SystemExit(f"{a.corpus}: every recording needs a source (run scripts/build_real_corpus.py again)")
    unknown = held - set(src)
    if unknown:
        raise SystemExit(f"no recordings of source(s) {sorted(unknown)}; the corpus has {sorted(set(src))}")
    try:
        variants, level_of = level_variants(json.loads(a.variants), a.level)
    except ParameterError as exc:
        raise SystemExit(f"--level: {exc}") from None
    library = corpus.subset([i for i, s in enumerate(src) if s not in held and s not in never])
    test = list(corpus.subset([i for i, s in enumerate(src) if s in held]))
    cca = fit_side_projections(corpus.subset([i for i, s in enumerate(src) if s not in held]), sides)
    feats = {side: [speech_features(r.audio, side) for r in test] for side in sides}
    seeds = parse_seeds(a.seeds)

    def test_all(motions, side):
        res = [cca[side].test(m, f, n_shifts=a.shifts, seed=i) for i, (m, f) in enumerate(zip(motions, feats[side]))]
        return pooled(res, n_shifts=a.shifts)

    rec = {side: test_all([r.motion for r in test], side) for side in sides}
    print(f"held out {'+'.join(sorted(held))}: {len(test)} recordings; library {len(library)} recordings; "
          "recorded heads " + ", ".join(f"{side} {rec[side]['excess']:+.3f} (p {rec[side]['p']:.3g})" for side in sides))
    print("| variant | speech side | " + " | ".join(f"seed {s}" for s in seeds) + " | mean excess | ratio to recorded heads |")
    print("|---|---|" + "---|" * (len(seeds) + 2))
    means: dict = {}
    for name, params in variants.items():
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = create("motion-match", **params).fit(library)
        takes = {s: [model.predict(r.audio, seed=s) for r in test] for s in seeds}
        for side in sides:
            cells, ex = [], []
            for s in seeds:
                p = test_all(takes[s], side)
                cells.append(f"{p['excess']:+.3f} ({p['p']:.3f})")
                ex.append(p["excess"])
            means[(name, side)] = float(np.mean(ex))
            print(f"| {name} | {side} | " + " | ".join(cells) + f" | {means[(name, side)]:+.3f} | "
                  + _r(ratio(means[(name, side)], rec[side]["excess"])) + " |", flush=True)
        print(f"  ({name}: {time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    if level_of:
        print("\nratio to level (mean excess over the level's, same side and seeds):")
        print("| variant | level | " + " | ".join(sides) + " |")
        print("|---|---|" + "---|" * len(sides))
        for name, lv in level_of.items():
            print(f"| {name} | {lv} | " + " | ".join(_r(ratio(means[(name, side)], means[(lv, side)]))
                                                      for side in sides) + " |")
    return 0


def _r(x: float) -> str:
    return f"{x:.2f}" if np.isfinite(x) else "–"


if __name__ == "__main__":
    raise SystemExit(main())
