"""The ``startup`` group of ``benchmarks/run.py``: whole commands as a user runs them.

Inside the library the default turns a minute of speech into motion in a fraction of a second;
what a user runs is the command, which also starts Python and imports what it uses.  Each row
here is a fresh process per run (``python -m headmotion ...``), the median of several runs after
a warm-up run, with the process's own peak RSS (VmHWM, :data:`harness.PEAK_RSS_CODE`):

* ``headmotion --help``;
* ``headmotion synth`` of 10 s and 60 s of speech with the shipped default model (no ``-m``)
  and with the shipped streaming model given by its path;
* ``headmotion stream`` with 16-bit PCM piped into stdin in real time from the moment the process
  starts: how late its first frame arrives (the process loads while the speech is arriving) and
  the median lateness after that (a frame is "late" by the time between the end of its audio and
  its JSON line: the model's lookahead plus the compute and the pipe), the median of 3 runs (1
  with ``--quick``) after a short warm-up run.

The commands run as an installed package does, with its modules' bytecode cached (pip compiles it
at install): a ``PYTHONDONTWRITEBYTECODE`` in the benchmark's environment is not passed on, or
every process would compile each module it imports from source (about 0.1 s of a live head's
first frame), and the warm-up runs write the cache.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from harness import PEAK_RSS_CODE, Row

RUNNER = PEAK_RSS_CODE + (
    "import sys\n"
    "from headmotion.cli import main\n"
    "try:\n"
    "    rc = main(sys.argv[1:])\n"
    "except SystemExit as exc:\n"
    "    rc = exc.code\n"
    "print('__RSS__', _peak_rss_mb(), file=sys.stderr)\n"
    "sys.exit(rc or 0)\n"
)
#: the children's environment: the benchmark's, with bytecode cached as an installed package has it
CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def command_runs(args: list[str], *, repeats: int, warmup: int = 1, timeout: float = 600) -> tuple[float, float]:
    """Median wall seconds and median peak RSS (MB) of ``headmotion ARGS`` in fresh processes."""
    walls, peaks = [], []
    for k in range(warmup + repeats):
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", RUNNER, *args], capture_output=True, text=True, timeout=timeout,
                             env=CHILD_ENV)
        wall = time.perf_counter() - t0
        if out.returncode != 0:
            raise RuntimeError(f"headmotion {' '.join(args)} failed: {out.stderr[-800:]}")
        if k >= warmup:
            walls.append(wall)
            peaks.append(float(next(l for l in out.stderr.splitlines() if l.startswith("__RSS__")).split()[1]))
    return statistics.median(walls), statistics.median(peaks)


def stream_lateness(model: Path, samples: np.ndarray, sample_rate: int, *, seconds: float) -> dict:
    """``headmotion stream -m MODEL`` fed ``seconds`` of 16-bit PCM on stdin in real time from the
    moment it is started: lateness of each JSON frame (arrival − end of the frame's audio)."""
    x = np.clip(np.asarray(samples[: int(seconds * sample_rate)]) * 32767.0, -32768, 32767).astype("<i2")
    chunk = sample_rate // 100
    proc = subprocess.Popen([sys.executable, "-m", "headmotion", "stream", "-m", str(model), "--input", "-",
                             "--sample-rate", str(sample_rate)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=CHILD_ENV)
    t0 = time.perf_counter()

    def write():
        try:
            for k in range(0, len(x), chunk):
                # chunk k has been "spoken" once its last sample's time has passed
                delay = t0 + (k + chunk) / sample_rate - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
                proc.stdin.write(x[k:k + chunk].tobytes())
                proc.stdin.flush()
        except BrokenPipeError:
            pass
        finally:
            proc.stdin.close()

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    arrivals, times = [], []
    for line in proc.stdout:
        now = time.perf_counter() - t0
        try:
            msg = json.loads(line)
        except ValueError:
            continue
        arrivals.append(now)
        times.append(float(msg["time"]))
    proc.wait(timeout=seconds + 120)
    writer.join(timeout=5)
    if not arrivals:
        raise RuntimeError("headmotion stream wrote no frames")
    # a frame's audio ends one frame after its time, at the model's rate (25 fps for the shipped
    # models; read from the frame times, not assumed)
    frame_s = float(np.median(np.diff(times))) if len(times) > 1 else 0.04
    late = [a - (t + frame_s) for a, t in zip(arrivals, times)]
    first = late[0]
    # frames emitted at flush (after the input ended: the last second) are not live frames
    live = [v for v, t in zip(late, times) if t + frame_s <= seconds - 1.0] or late
    return {"first_s": first, "median_ms": 1000 * float(np.median(live)), "p95_ms": 1000 * float(np.percentile(live, 95)),
            "frames": len(late)}


def bench_startup(res, quick: bool, *, speech_audio, stream_model: Path):
    import soundfile as sf

    reps = 3 if quick else 5
    wall, rss = command_runs(["--help"], repeats=reps)
    res.add(Row("0 startup", "headmotion --help (fresh process)", wall, "s", "<= 0.3 s", wall <= 0.3,
                f"peak RSS {rss:.0f} MB; median of {reps} after a warm-up"))
    peaks = []
    with tempfile.TemporaryDirectory(prefix="hm-startup-") as tmp:
        for secs, target in ((10.0, 0.8), (60.0, 1.2)):
            audio = speech_audio(secs, seed=1)
            wav = Path(tmp) / f"speech_{int(secs)}s.wav"
            sf.write(wav, audio.samples, audio.sample_rate)
            for label, model in (("default model", None), ("streaming model (-m its path)", stream_model)):
                args = ["synth", str(wav), "-o", str(Path(tmp) / "out.bvh")]
                if model is not None:
                    args += ["-m", str(model)]
                wall, rss = command_runs(args, repeats=reps)
                peaks.append(rss)
                res.add(Row("0 startup", f"headmotion synth {secs:g} s of speech, {label}", wall, "s",
                            f"<= {target:g} s", wall <= target, f"peak RSS {rss:.0f} MB; whole process, "
                            f"median of {reps}"))
        res.add(Row("0 startup", "peak RSS of those synth commands (largest)", max(peaks), "MB", "<= 300 MB",
                    max(peaks) <= 300, "VmHWM of each process"))
        audio = speech_audio(8.0 if quick else 15.0, seed=2)
        stream_lateness(stream_model, audio.samples, audio.sample_rate, seconds=2.0)  # warm-up
        runs = [stream_lateness(stream_model, audio.samples, audio.sample_rate, seconds=audio.duration)
                for _ in range(1 if quick else 3)]
        lat = sorted(runs, key=lambda r: r["first_s"])[len(runs) // 2]  # the run of the median first frame
        firsts = ", ".join(f"{r['first_s']:.3f}" for r in runs)
        res.add(Row("0 startup", "headmotion stream, speech piped from its start: first frame late by",
                    lat["first_s"], "s", "<= 0.3 s", lat["first_s"] <= 0.3,
                    f"median of {len(runs)} after a warm-up ({firsts} s); then median {lat['median_ms']:.0f} ms, "
                    f"p95 {lat['p95_ms']:.0f} ms late over {lat['frames']} frames (lookahead + compute + pipe); "
                    f"shipped streaming model"))


__all__ = ["bench_startup", "command_runs", "stream_lateness", "RUNNER"]
