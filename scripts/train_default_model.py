"""Train the default model shipped in ``src/headmotion/data/default_model.hmz``.

tws-hier (thesis §5.6–5.8) on the real talking-video corpus built by
``scripts/build_real_corpus.py`` (all speakers pooled: the default must be speaker-independent),
F0 + energy features, motion resampled to 100 frames/s (the thesis's rate; the segmentation
parameters are defined there).  Usage::

    python scripts/train_default_model.py [CORPUS_DIR] [-o OUT.hmz]
"""

import argparse
import time
from pathlib import Path

from headmotion.corpus import Corpus
from headmotion.systems import create

ap = argparse.ArgumentParser()
ap.add_argument("corpus", nargs="?", default=str(Path.home() / ".cache/headmotion/corpus/talking_video"))
ap.add_argument("-o", "--output", default=str(Path(__file__).resolve().parents[1] / "src/headmotion/data/default_model.hmz"))
ap.add_argument("--features", default="f0e")
a = ap.parse_args()
c = Corpus.load(a.corpus)
print(c.summary())
t = time.time()
m = create("tws-hier", features=a.features, fps=100.0).fit(c, progress=lambda d, n, s: print(f"  {d}/{n} {s}", flush=True))
print(f"trained in {time.time() - t:.1f} s; clusters {m.fit_info_['k']}")
m.save(a.output)
print("saved", a.output, Path(a.output).stat().st_size, "bytes")
