"""The ``batch`` group of ``benchmarks/run.py``: a voice-line library in one call
(:func:`headmotion.batch.synthesize_batch`, what ``headmotion synth IN... -o DIR`` runs).

50 files (10 with ``--quick``) copied from the real speech (5–29 s each), made with the shipped
default into BVH, in this process after a warm-up, the median of 3 runs (every output made again):

* one job against two worker processes: the speed-up (target on 2 cores: at least 1.7×);
  beside it, a perfectly parallel control measured at the same moments — two busy loops in two
  processes against one after the other — says how much of 2 cores the machine gave (on a shared
  machine the control itself falls short of 2×);
* the cost per file beyond synthesis: one job's batch time less the time of
  :func:`headmotion.synthesize` on the same files in a loop (loading the audio included), over the
  number of files — finding the inputs, hashing them, writing BVH, the manifest (target ≤ 50 ms).
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from harness import Row, time_median


def _library(src: Path, dest: Path, n: int) -> list[Path]:
    speech = sorted(p for p in src.iterdir() if p.suffix.lower() in (".wav", ".flac"))
    files = []
    for i in range(n):
        s = speech[i % len(speech)]
        files.append(dest / f"line{i:03d}{s.suffix}")
        shutil.copy(s, files[-1])
    return files


def _spin(n: int) -> int:
    x = 0
    for i in range(n):
        x += i
    return x


def _control_speedup() -> float:
    """Two busy loops one after the other ÷ the same in two processes."""
    from concurrent.futures import ProcessPoolExecutor

    n = 4_000_000
    one = time_median(lambda: (_spin(n), _spin(n)), repeats=3, warmup=0)
    with ProcessPoolExecutor(2) as ex:
        list(ex.map(_spin, [1, 1]))
        two = time_median(lambda: list(ex.map(_spin, [n, n])), repeats=3, warmup=0)
    return one / two


def bench_batch(res, quick: bool, *, speech_dir: Path) -> None:
    from headmotion.batch import synthesize_batch
    from headmotion.synthesis import load_model, synthesize

    n = 10 if quick else 50
    model = load_model("default")
    with tempfile.TemporaryDirectory() as tmp:
        lib = Path(tmp) / "lines"
        lib.mkdir()
        files = _library(speech_dir, lib, n)
        seconds = sum(m.duration for m in (synthesize(f, model)[0] for f in files))  # also the warm-up

        def batch(jobs: int):
            r = synthesize_batch([lib], Path(tmp) / f"out{jobs}", model, format="bvh", jobs=jobs, force=True)
            assert len(r.written) == n, r.failed

        batch(1)
        one = time_median(lambda: batch(1), repeats=3, warmup=0)
        two = time_median(lambda: batch(2), repeats=3, warmup=0)
        synth = time_median(lambda: [synthesize(f, model) for f in files], repeats=3, warmup=0)
        control = _control_speedup()
    speedup = one / two
    res.add(Row("10 batch", f"synth of {n} files ({seconds / 60:.1f} min of speech) to BVH: 2 jobs vs 1",
                speedup, "×", ">= 1.7×", speedup >= 1.7,
                f"1 job {one:.2f} s ({n / one:.1f} files/s), 2 jobs {two:.2f} s ({n / two:.1f} files/s); "
                f"perfectly parallel control {control:.2f}× on this machine now"))
    overhead = (one - synth) / n * 1000
    res.add(Row("10 batch", "cost per file beyond synthesis (1 job)", overhead, "ms", "<= 50 ms", overhead <= 50,
                f"synthesize() alone {synth / n * 1000:.1f} ms a file; batch {one / n * 1000:.1f} ms a file"))
