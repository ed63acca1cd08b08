"""What reading the other party's pitch costs the listening head, per reader
(``headmotion.listener.head.HEARD_READER``; docs/decisions/listen-to-anyone.md).

Speech of the benchmarks' real-speech source (``benchmarks/inputs.py``), resampled to the layer's
8 kHz and fed to each reader in 1 s batches, as the layer analyses what it has gathered when no cue
can be due yet (``--chunk-ms 20``: 20 ms at a time, as it analyses while the other speaks); process CPU
per 10 ms of heard audio and per push, the least of ``--repeats`` runs.

    python research/listen_to_anyone/heard_reader_cost.py --seconds 57 [--chunk-ms 20]
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=57.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--chunk-ms", type=float, default=1000.0, help="heard audio per push (ms)")
    args = ap.parse_args(argv)

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from inputs import speech_audio

    from headmotion.features.readers import f0e_stream
    from headmotion.io.resampler import Resampler
    from headmotion.listener.head import ANALYSIS_FPS, HEAR_RATE

    audio = speech_audio(args.seconds, seed=3)
    x = Resampler(audio.sample_rate, HEAR_RATE, quality="LQ")(audio.samples, last=True)
    step = max(1, int(round(args.chunk_ms / 1000.0 * HEAR_RATE)))
    for name, kw in READERS.items():
        costs = []
        for _ in range(args.repeats):
            reader = f0e_stream(sample_rate=HEAR_RATE, fps=ANALYSIS_FPS, smooth_frames=1, smooth_lookahead=0,
                                delta_lookahead=0, voicing=True, **kw)
            t = time.process_time()
            for k in range(0, len(x), step):
                reader.push(x[k:k + step])
            reader.flush()
            costs.append(time.process_time() - t)
        print(f"{name}: {min(costs) / (len(x) / (HEAR_RATE / 100)) * 1e3:.3f} ms of process CPU per 10 ms heard, "
              f"{min(costs) / -(-len(x) // step) * 1e3:.3f} ms per push of {args.chunk_ms:g} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
