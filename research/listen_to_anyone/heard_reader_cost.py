"""What reading the other party's pitch costs the listening head, per reader
(``headmotion.listener.head.HEARD_READER``; docs/decisions/listen-to-anyone.md).

A conversation of the benchmarks' real speech (``benchmarks/inputs.py``): for ``--seconds`` the
other party speaks while this head is silent, then this head speaks while the other is silent.  A
``stream`` of the shipped model hears it as a live path does, ``--chunk-ms`` of each at a time
(the heard audio, then the speech).  Counted: the layer's analyses of the heard audio (its pitch
reader's pushes) in each half, their process CPU per 10 ms of conversation and the dearest one; the
least of ``--repeats`` runs.  Then what a stream that hears costs against one that only speaks, as
``benchmarks/run.py``'s "hearing the other party too" row measures it, but with three streams
pushed in turn, 10 ms at a time on one BLAS thread — speaking alone and hearing with each reader,
which goes first rotating — so that the machine's other work falls on all three alike.

    python research/listen_to_anyone/heard_reader_cost.py [--seconds 20] [--chunk-ms 20] [--paired-seconds 60]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

READERS = {
    "praat blocks of 0.25 s, each with the 0.3 s before it": {"reader": "praat", "praat_block": 25,
                                                              "praat_back_s": 0.3},
    "praat-path (each analysis frame read once)": {"reader": "praat-path"},
}


def run(model, own, heard, sr: int, chunk: int, half: int):
    """[(analyses, seconds of process CPU, dearest one)] of the two halves."""
    import headmotion.listener.head as head
    from headmotion.synthesis import open_stream

    log = []
    analyse = head.ListeningLayer._analyse

    def timed(self, x, flush=False):
        t = time.process_time()
        analyse(self, x, flush)
        log.append((at[0], time.process_time() - t))

    at = [0]
    head.ListeningLayer._analyse = timed
    try:
        s = open_stream(model, seed=0, heard_rate=sr)
        for k in range(0, len(own), chunk):
            at[0] = k
            s.hear(heard[k:k + chunk])
            s.push(own[k:k + chunk])
        s.flush()
    finally:
        head.ListeningLayer._analyse = analyse
    halves = [[c for k, c in log if (k < half) == first] for first in (True, False)]
    return [(len(h), sum(h), max(h, default=0.0)) for h in halves]


def paired(model, speech, other, sr: int, repeats: int) -> None:
    """Process CPU per 10 ms chunk of a stream speaking alone and of one hearing ``other`` with each
    reader, the three pushed in turn."""
    from threadpoolctl import threadpool_limits

    import headmotion.listener.head as head
    from headmotion.synthesis import open_stream

    chunk = sr // 100

    class Hearing:
        def __init__(self, kw):
            head.HEARD_READER = kw
            self.s, self.k = open_stream(model, seed=0, heard_rate=sr), 0
            self.s.hear(other[:0])  # builds the listening layer with this reader now

        def push(self, x):
            self.s.hear(other[self.k:self.k + len(x)])
            self.k += len(x)
            return self.s.push(x)

    with threadpool_limits(limits=1, user_api="blas"):
        for _ in range(repeats):
            streams = {"speaking alone": model.stream(seed=0), **{name: Hearing(kw) for name, kw in READERS.items()}}
            names, cost = list(streams), dict.fromkeys(streams, 0.0)
            starts = range(0, len(speech), chunk)
            for i, k in enumerate(starts):
                for name in names[i % len(names):] + names[:i % len(names)]:
                    t = time.process_time()
                    streams[name].push(speech[k:k + chunk])
                    cost[name] += time.process_time() - t
            alone = cost["speaking alone"]
            print("; ".join(f"{name}: {c / len(starts) * 1e3:.3f} ms per chunk ({c / alone:.2f}x)"
                            for name, c in cost.items()))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="length of each half")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--chunk-ms", type=float, default=20.0, help="audio per push (ms)")
    ap.add_argument("-m", "--model", default="stream")
    ap.add_argument("--paired-seconds", type=float, default=60.0, help="speech for the paired measure (0: none)")
    args = ap.parse_args(argv)

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import numpy as np
    from inputs import speech_audio

    import headmotion.listener.head as head
    from headmotion.synthesis import load_model

    model = load_model(args.model)
    sr = 16000
    n = int(args.seconds * sr)
    a = speech_audio(args.seconds, seed=2).samples[:n]
    b = speech_audio(args.seconds, seed=3).samples[:n]
    own = np.concatenate([np.zeros(n, np.float32), a])
    heard = np.concatenate([b, np.zeros(n, np.float32)])
    chunk = max(1, int(round(args.chunk_ms / 1000.0 * sr)))
    shipped = dict(head.HEARD_READER)
    try:
        for name, kw in READERS.items():
            head.HEARD_READER = kw
            runs = [run(model, own, heard, sr, chunk, n) for _ in range(args.repeats)]
            for i, what in enumerate(("the other speaks, this head silent", "this head speaks, the other silent")):
                calls, cpu, dear = min((r[i] for r in runs), key=lambda c: c[1])
                print(f"{name} | {what}: {calls} analyses, {cpu / (args.seconds * 100) * 1e3:.3f} ms of process "
                      f"CPU per 10 ms, the dearest {dear * 1e3:.1f} ms")
        if args.paired_seconds > 0:
            paired(model, speech_audio(args.paired_seconds, seed=2).samples,
                   speech_audio(args.paired_seconds, seed=3).samples, sr, 2)
    finally:
        head.HEARD_READER = shipped
    return 0


if __name__ == "__main__":
    sys.exit(main())
