#!/usr/bin/env python
"""How the shipped models' Praat reading voices each recording against whole-file Praat
(docs/decisions/read-any-voice.md, "the silence threshold"): per recording of the held-out sources
named, the share of 25 fps frames whole-file Praat calls voiced, the live reading (last 0.3 s per
frame, or ``--reader praat-path``: each analysis frame read once, the path searched forward;
``--half-life 0``: each read's own peak as Praat's silence reference) and YIN at 0.45, and
the share the live reading calls voiced where whole-file Praat does not, and the converse.

    python research/read_any_voice/live_voicing.py ~/.cache/headmotion/corpus/talking_video \\
        --sources mimictalk,video_retalking,sadtalker,pc_avs [--half-life 0]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    from headmotion.corpus import Corpus
    from headmotion.evaluation.protocol.folds import source_of
    from headmotion.features import extract
    from headmotion.features.prosody import praat_pitch
    from headmotion.systems.motion_match.library import PRAAT_LIVE

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("--sources", default="mimictalk,video_retalking,sadtalker,pc_avs")
    ap.add_argument("--half-life", type=float, default=None, help="peak_half_life_s of the live reading")
    ap.add_argument("--reader", default="praat", choices=("praat", "praat-path"),
                    help="the live reading: Praat on the last 0.3 s per frame, or each analysis frame once")
    a = ap.parse_args(argv)
    live = dict(PRAAT_LIVE) if a.reader == "praat" else {"reader": "praat-path"}
    live.update({} if a.half_life is None else {"peak_half_life_s": a.half_life})
    corpus = Corpus.load(a.corpus)
    wanted = set(a.sources.split(","))
    rows = []
    print("| recording | source | voiced: Praat / live / YIN 0.45 | live, not Praat | Praat, not live |")
    print("|---|---|---|---|---|")
    for rec, entry in zip(corpus, corpus.entries):
        src = source_of(entry)
        if src not in wanted:
            continue
        audio = rec.audio
        n = int(len(audio.samples) / audio.sample_rate * 25)
        _, whole = praat_pitch(audio, fps=25, n_frames=n)
        lv = extract("f0e-live", audio, fps=25, n_frames=n, voicing=True, **live).values[:, -1] > 0.5
        yin = extract("f0e-live", audio, fps=25, n_frames=n, voicing=True, voicing_threshold=0.45).values[:, -1] > 0.5
        rows.append(((lv & ~whole).mean(), (whole & ~lv).mean()))
        print(f"| {entry.recording} | {src} | {whole.mean():.2f} / {lv.mean():.2f} / "
              f"{yin.mean():.2f} | {rows[-1][0]:.2f} | {rows[-1][1]:.2f} |")
    r = np.array(rows)
    print(f"\nmedian over {len(r)} recordings: live not Praat {np.median(r[:, 0]):.3f}, Praat not live "
          f"{np.median(r[:, 1]):.3f}; max {r[:, 0].max():.2f} / {r[:, 1].max():.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
