"""The live engine in-process: N streams of the shipped ``stream`` model pushed 20 ms at a time,
each alone (``HeadMotionCore.push``) and together (one tick per push, ``run_together``), the
process's CPU per stream; no server, one BLAS thread.

    python benchmarks/engine_bench.py --streams 32 --modes alone,together
    PYTHONPATH=/tmp/before/src python benchmarks/engine_bench.py --modes alone   # another version's tree

Prints each mode's CPU per stream (% of a core) and the load average beside it.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--streams", type=int, default=32)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--modes", default="alone,together", help="alone, together (a tree with the engine)")
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    from headmotion.live.core import HeadMotionCore
    from headmotion.synthesis import load_model
    from serve_bench import speech_pcm

    model = load_model("stream")
    xs = [speech_pcm(args.seconds, seed=s).astype(np.float32) / 32768 for s in range(4)]
    chunk, n = 320, args.streams
    with threadpool_limits(1, "blas"):
        for mode in args.modes.split(","):
            cores = [HeadMotionCore(model, seed=k) for k in range(n)]
            t0 = time.process_time()
            for i in range(0, int(args.seconds * 16000), chunk):
                if mode == "alone":
                    for k, c in enumerate(cores):
                        c.push(xs[k % 4][i:i + chunk], 16000)
                else:
                    from headmotion.live.engine import run_together

                    run_together([c.push_steps(xs[k % 4][i:i + chunk], 16000) for k, c in enumerate(cores)])
            cpu = time.process_time() - t0
            print(f"{mode:9s} {n} streams: {100 * cpu / (n * args.seconds):.2f}% of a core per stream; "
                  f"load average {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main()
