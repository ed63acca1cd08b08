"""How much of the pooled speed-histogram Hellinger is sampling noise (issue 14, eighth session).

The speed target compares one pooled histogram of the held-out recorded heads with one of a
system's output (50 bins, GENEA-style).  A system that drew its speeds from *exactly* the recorded
heads' distribution would still score above 0, because its histogram is a finite sample.  This
script measures that floor on the recorded heads themselves: the pooled histogram of all
(held-out) speeds against the histogram of a resample of the same size — iid frames (the lower
bound) and 1-s blocks (motion is autocorrelated, so its effective sample is smaller) — 200 draws
each, median and 90th percentile.

    PYTHONPATH=src python scripts/diagnosis_i14/speed_hellinger_noise.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from headmotion.corpus import Corpus
from headmotion.evaluation import realism as R


def speeds(path: Path, *, exclude=("mead_lrs3",), min_s: float = 4.0) -> list[np.ndarray]:
    out = []
    for r in Corpus.load(path):
        if r.id.startswith(exclude) or r.duration < min_s:
            continue
        out.append(R.speed(r.motion))
    return out


def floor(per_rec: list[np.ndarray], fps_block: int, rng: np.random.Generator, draws: int = 200):
    ref = np.concatenate(per_rec)
    iid, blk = [], []
    for _ in range(draws):
        iid.append(R.hellinger_values(ref, rng.choice(ref, len(ref), replace=True)))
        parts, n = [], 0
        while n < len(ref):
            x = per_rec[rng.integers(len(per_rec))]
            a = rng.integers(max(1, len(x) - fps_block))
            parts.append(x[a:a + fps_block])
            n += len(parts[-1])
        blk.append(R.hellinger_values(ref, np.concatenate(parts)[:len(ref)]))
    q = lambda v: f"{np.median(v):.3f} (90th pct {np.percentile(v, 90):.3f})"  # noqa: E731
    return len(ref), q(iid), q(blk)


def main():
    rng = np.random.default_rng(0)
    home = Path.home() / ".cache/headmotion/corpus"
    sets = {"video (37 recordings >= 4 s, no mead_lrs3)": (home / "talking_video", 25)}
    zc = Path("/tmp/zc")
    if (zc / "corpus.csv").exists():
        sets["ZEGGS take (headmotion corpus import ... -o /tmp/zc)"] = (zc, None)
    for name, (path, blk) in sets.items():
        per = speeds(path)
        fps = 25 if blk else None
        if blk is None:
            c = Corpus.load(path)
            fps = int(round(c[0].motion.fps))
        n, iid, block = floor(per, fps, rng)
        print(f"{name}: {n} speeds; H against a resample of itself: iid {iid}; 1-s blocks {block}")


if __name__ == "__main__":
    main()
