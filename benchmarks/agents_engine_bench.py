"""Many Pipecat processors in one process, on the event loop's shared engine (``engine=True``, the
default) and each deciding alone (``engine=False``): N processors in one loop, each fed the
bundled short speech as TTS audio frames of 20 ms as fast as the pipeline takes them (``pace`` off),
the process's CPU per second of speech per processor; interleaved runs, one BLAS thread.  Needs
Pipecat (run it with the environment ``scripts/test-integrations.sh`` makes).

    .venv-integrations/pipecat/bin/python benchmarks/agents_engine_bench.py --agents 32 --runs 6

Prints every run, then each mode's median and range.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


async def _run(n: int, engine: bool, pcm) -> tuple[float, object]:
    from pipecat.frames.frames import TTSAudioRawFrame, TTSStartedFrame, TTSStoppedFrame
    from pipecat.tests.utils import run_test

    from headmotion.integrations.pipecat import HeadMotionProcessor

    def frames():
        audio = [TTSAudioRawFrame(audio=pcm[i:i + 320].tobytes(), sample_rate=16000, num_channels=1)
                 for i in range(0, len(pcm), 320)]
        return [TTSStartedFrame(), *audio, TTSStoppedFrame()]

    procs = [HeadMotionProcessor(pace=False, lookahead_ms=0, seed=k, engine=engine) for k in range(n)]
    cpu = time.process_time()
    await asyncio.gather(*(run_test(p, frames_to_send=frames()) for p in procs))
    return time.process_time() - cpu, procs[0].engine.engine


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--agents", type=int, default=32)
    ap.add_argument("--runs", type=int, default=6, help="runs of each mode, interleaved")
    args = ap.parse_args()
    from loguru import logger

    logger.remove()
    sys.path.insert(0, str(ROOT / "tests"))
    from agent_helpers import speech_pcm

    from headmotion.live.blas import one_blas_thread

    one_blas_thread()
    pcm = speech_pcm(16000)
    seconds = len(pcm) / 16000
    got: dict[bool, list[float]] = {True: [], False: []}
    for r in range(args.runs):
        for engine in ((True, False) if r % 2 == 0 else (False, True)):
            cpu, eng = asyncio.run(_run(args.agents, engine, pcm))
            share = 100 * cpu / args.agents / seconds
            got[engine].append(share)
            ticks = f"; {eng.stats.ticks} ticks of {eng.stats.mean_batch:.1f} decisions" if eng else ""
            print(f"run {r + 1} engine={engine}: {share:.2f} % of a core per agent{ticks}")
    for engine, shares in got.items():
        print(f"engine={engine}: median {statistics.median(shares):.2f} % ({min(shares):.2f}-{max(shares):.2f}) "
              f"of a core per agent, {args.agents} agents, {len(shares)} runs")


if __name__ == "__main__":
    main()
