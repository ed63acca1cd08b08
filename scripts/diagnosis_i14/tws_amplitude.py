"""How large the template systems' motion is against the heads they learnt from (issue 14, tenth
session): on the ZEGGS take in four folds at pauses, each fold held out in turn, the SD per axis
(pitch / yaw / roll, degrees) of

* the recorded heads of the held-out fold and of the three training folds,
* the system's synthesis of the held-out fold (mean over synthesis seeds 0–3),
* its synthesis of its own training speech (recording k with seed k),

with ``amplitude_match`` off and on.  Without it tws-hier moved 1.3–1.5× the heads' SD in pitch
and roll on its *own* training speech (fold 0); with it 1.2×.  The gains are measured on the
cross-fitted calibration synthesis (half models on the folds they were not trained on), which
they bring onto the heads' SD exactly; the full model, trained on all three folds, moves more
than its halves do, so its own synthesis stays a little wider.

    headmotion corpus import ../shared/data/mocap_speech/zeggs/067_Speech_2_x_1_0.bvh \\
        ../shared/data/mocap_speech/zeggs/067_Speech_2_x_1_0.wav -o /tmp/zc --speaker zeggs --task mocap
    PYTHONPATH=src python scripts/diagnosis_i14/tws_amplitude.py [/tmp/zc] [--system tws-hier]
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from headmotion.corpus import Corpus
from headmotion.evaluation.pause_folds import split_corpus_at_pauses
from headmotion.rotations import rotvec_to_pitch_yaw_roll
from headmotion.systems.base import create


def sd(rotvec) -> np.ndarray:
    """SD per axis (pitch, yaw, roll) in degrees."""
    return rotvec_to_pitch_yaw_roll(np.asarray(rotvec), degrees=True).std(axis=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", nargs="?", default="/tmp/zc")
    ap.add_argument("--system", default="tws-hier")
    ap.add_argument("--folds", type=int, default=4)
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    corpus, _ = split_corpus_at_pauses(Corpus.load(a.corpus), a.folds)
    recs = list(corpus)
    fmt = lambda v: "/".join(f"{x:4.1f}" for x in v)  # noqa: E731
    print(f"{a.system}: SD pitch/yaw/roll (deg)")
    for i, held in enumerate(recs):
        train = [r for j, r in enumerate(recs) if j != i]
        heads = np.mean([sd(r.motion.rotvec) for r in train], axis=0)
        print(f"fold {i}: held-out heads {fmt(sd(held.motion.rotvec))}   training heads {fmt(heads)}")
        for on in (False, True):
            m = create(a.system, amplitude_match=on).fit(Corpus(train, sample_rate=recs[0].audio.sample_rate))
            out = np.mean([sd(m.predict(held.audio, seed=s).rotvec) for s in range(4)], axis=0)
            own = np.mean([sd(m.predict(r.audio, seed=k).rotvec) for k, r in enumerate(train)], axis=0)
            print(f"   amplitude_match={str(on):5s}  held-out synthesis {fmt(out)}   own training speech {fmt(own)}")


if __name__ == "__main__":
    main()
