"""How far apart two *recorded* sets of head motion are on the pooled realism measures (issue 14,
sixth session): the floor under the speed-histogram and spectral targets.

The targets' anchor is the recording's own motion circularly shifted ("shifted"), whose speed
histogram and band shares are the recording's exactly, so its pooled Hellinger is ~0.01 and the
bar (anchor + 0.05) asks a system to be closer to the recorded set than another stretch of the
same heads is.  This script measures that: on the video corpus (recordings ≥ 4 s, no mead_lrs3)
random halves of the recordings against each other, and the evaluation's speaker folds against the
other folds; on the ZEGGS take (``headmotion corpus import`` into /tmp/zc) its halves and its four
parts against the rest.

    PYTHONPATH=src python scripts/diagnosis_i14/realisation_floor.py [--zeggs /tmp/zc]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from dnn_band_sweep import corpus  # noqa: E402

from headmotion.corpus import Corpus  # noqa: E402
from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.evaluation.protocols import make_folds  # noqa: E402
from headmotion.types import Motion  # noqa: E402


def pooled(motions):
    """Pooled speeds and mean band shares of a list of motions."""
    return (np.concatenate([R.speed(m) for m in motions]),
            np.mean([R.band_shares(m) for m in motions], axis=0))


def compare(a, b):
    (sa, ba), (sb, bb) = pooled(a), pooled(b)
    return R.hellinger_values(sa, sb), R.mean_shares_distance([ba], [bb])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--zeggs", default="/tmp/zc")
    ap.add_argument("--draws", type=int, default=20)
    a = ap.parse_args()
    c = corpus()
    motions = [r.motion for r in c]
    rng = np.random.default_rng(0)
    hs, ls = [], []
    for _ in range(a.draws):
        ids = rng.permutation(len(motions))
        h, l1 = compare([motions[i] for i in ids[: len(ids) // 2]], [motions[i] for i in ids[len(ids) // 2:]])
        hs.append(h)
        ls.append(l1)
    print(f"video corpus, {len(motions)} recordings: random half against the other half ({a.draws} draws): "
          f"speed Hellinger median {np.median(hs):.3f} ({min(hs):.3f}–{max(hs):.3f}), "
          f"pooled L1 median {np.median(ls):.3f} ({min(ls):.3f}–{max(ls):.3f})")
    for seed in (0, 1):
        folds = [[r.motion for r in test] for _, _, test, _ in make_folds(c, "speakers", seed=seed, speaker_folds=3)]
        out = [compare(folds[i], [m for j, f in enumerate(folds) if j != i for m in f]) for i in range(3)]
        print(f"video corpus, speaker folds of --seed {seed}: each fold against the others: speed Hellinger "
              + " ".join(f"{h:.3f}" for h, _ in out) + ", pooled L1 " + " ".join(f"{x:.3f}" for _, x in out))
    if Path(a.zeggs).exists():
        m = Corpus.load(a.zeggs)[0].motion
        rv = m.rotvec
        parts = [Motion(rv[i], m.fps) for i in np.array_split(np.arange(len(rv)), 2)]
        h, l1 = compare(parts[:1], parts[1:])
        print(f"ZEGGS take ({len(rv) / m.fps:.0f} s): first half against second half: speed Hellinger {h:.3f}, L1 {l1:.3f}")
        q = [Motion(rv[i], m.fps) for i in np.array_split(np.arange(len(rv)), 4)]
        out = [compare([q[i]], [q[j] for j in range(4) if j != i]) for i in range(4)]
        print("ZEGGS take, each quarter against the other three: speed Hellinger "
              + " ".join(f"{x:.3f}" for x, _ in out) + ", L1 " + " ".join(f"{x:.3f}" for _, x in out))
    else:
        print(f"{a.zeggs} not found: import the ZEGGS take first (see the docstring)")


if __name__ == "__main__":
    main()
