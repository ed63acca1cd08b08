"""A head that waits: the recorded pauses' speeds beside each model's speed and loop index through
20 s of silence (docs/decisions/amount-and-adapt.md).

    python scripts/waiting_check.py ~/.cache/headmotion/corpus/talking_video --models default stream \
        --variants '{"repeat 3, pause 3": {"repeat_cost": 3, "pause_weight": 3}}'

Each variant is the first model with those parameters set.  Speech speed for the ratio: the speech
files of ../shared/data/speech (speech no model was built from).
"""

from __future__ import annotations

import argparse
import copy
import glob
import json
from pathlib import Path

import numpy as np

from headmotion.corpus import Corpus
from headmotion.evaluation.measures.realism import limit_cycle_index
from headmotion.evaluation.measures.waiting import pause_segment_speeds, waiting
from headmotion.io import load_audio
from headmotion.synthesis import load_model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("--models", nargs="+", default=["default", "stream"])
    ap.add_argument("--variants", default="{}", help="JSON: name → parameters set on the first model")
    ap.add_argument("--speech", default=str(Path(__file__).resolve().parents[1].parent / "shared/data/speech"))
    ap.add_argument("--exclude", default="mead_lrs3")
    args = ap.parse_args()
    c = Corpus.load(args.corpus)
    recs = [r for r in c if not r.id.startswith(args.exclude) and r.duration >= 4]
    ps = pause_segment_speeds(recs)
    lc = np.median([limit_cycle_index(r.motion)[0] for r in recs])
    p10, p50, p90 = ps.percentiles()
    print(f"recorded pauses: {len(ps.segments)} segments, speed {p10:.1f}–{p90:.1f} °/s (10th–90th), median {p50:.1f}; "
          f"pause/speech {ps.ratio:.2f}; loop index of the recordings (median) {lc:.2f}")
    speech = [load_audio(f) for f in sorted(glob.glob(f"{args.speech}/*.wav"))]
    rows = {name: load_model(name) for name in args.models}
    for name, params in json.loads(args.variants).items():
        m = copy.copy(rows[args.models[0]])
        m.set_params(**params)
        rows[name] = m
    print("| model | silence speed (°/s, per seed) | silence / speech | loop index (per seed) |")
    print("|---|---|---|---|")
    for name, m in rows.items():
        w = waiting(m, speech=speech)
        print(f"| {name} | {' '.join(f'{v:.1f}' for v in w.speed)} | {w.ratio:.2f} | {' '.join(f'{v:.2f}' for v in w.loop)} |")


if __name__ == "__main__":
    main()
