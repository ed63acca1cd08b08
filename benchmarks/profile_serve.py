"""Where one ``headmotion serve`` worker's time goes under paced streams: the worker runs under
pyinstrument (in-process, one worker), N paced real-time streams of 20 ms chunks are sent to it
(``serve_bench.stream_level``: the load client on the same cores), then the worker is stopped and
its profile written.

    python benchmarks/profile_serve.py --streams 16 --seconds 10 --out /tmp/serve-profile.txt

Prints the level's p50 / p95 latency, the server's CPU per stream, the load average and the
share of the worker's samples in each part of the path (the live engine's stages, Praat, the
library search, the WebSocket layers); the full call tree is in ``--out``.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

#: the parts of the path the summary counts, by function names in the call tree
PARTS = (("Praat pitch (to_pitch_ac)", ("to_pitch_ac",)),
         ("Praat reader, all (Praat's call included)", ("StreamingPraatF0e.push", "PraatPathF0e.push",
                                                         "PraatPathF0e.push_steps", "answer_many")),
         ("the live core's push, in the stream's task", ("HeadMotionCore.push", "HeadMotionCore.push_steps")),
         ("the engine's ticks (decisions answered)", ("LiveEngine._run_tick",)),
         ("the stream's session (all its work)", ("Session.run",)),
         ("library costs", ("Library.costs", "Library.costs_many")),
         ("the draw among the cheapest", ("draw",)),
         ("decision inputs (descriptor, goal)", ("live_inputs",)),
         ("pose conversion", ("_degrees_to_motion",)),
         ("frames message", ("frames_message",)),
         ("WebSocket send", ("send_bytes",)),
         ("WebSocket receive", ("Session._receive",)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--streams", type=int, default=16)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--out", default=None, help="the pyinstrument text report (default: a temporary file)")
    ap.add_argument("--src", default=None, help="the package's source folder the worker runs (default: this "
                                                 "checkout's src; another version's, to compare)")
    ap.add_argument("--no-profile", action="store_true", help="the worker without the profiler (its CPU alone)")
    args = ap.parse_args()
    from serve_bench import Server, speech_pcm, stream_level

    out = args.out or tempfile.mktemp(prefix="hm-serve-profile-", suffix=".txt")
    prefix = None if args.no_profile else [sys.executable, "-m", "pyinstrument", "-r", "text", "--show-all", "-o", out]
    srv = Server(prefix=prefix, src=None if args.src is None else Path(args.src))
    pool = [speech_pcm(args.seconds, seed=s) for s in range(4)]
    try:
        load0 = os.getloadavg()[0]
        r = stream_level(srv, args.streams, args.seconds, pool)
        load1 = os.getloadavg()[0]
    finally:
        srv.proc.send_signal(signal.SIGINT)
        try:
            srv.proc.wait(60)
        except subprocess.TimeoutExpired:
            srv.proc.kill()
        srv.log.close()
    for _ in range(0 if args.no_profile else 50):
        if Path(out).exists() and Path(out).stat().st_size:
            break
        time.sleep(0.1)
    print(f"{args.streams} paced streams of {args.seconds:g} s: p50 {r['p50']:.1f} ms, p95 {r['p95']:.1f} ms, "
          f"every frame {r['complete']}, server CPU {100 * r['cpu_per_stream_s']:.2f}% of a core per stream, "
          f"load client {100 * r['client_cpu_per_stream_s']:.2f}%; other programs {r['others_cores']:.2f} cores; "
          f"load average {load0:.2f} -> {load1:.2f}" + ("" if r["complete"] else f"; errors {r['errors']}"))
    eng = engine_stats(Path(srv.log.name))
    if eng is not None:
        ticks, decisions, largest, *more = eng
        if more:   # the pitch reads asked of the engine, and the ticks that made a decision
            reads, decision_ticks = more
            print(f"the worker's engine: {ticks} ticks; {decisions} decisions in {decision_ticks} of them "
                  f"({decisions / max(decision_ticks, 1):.2f} a tick); {reads} pitch reads "
                  f"({reads / max(ticks, 1):.2f} a tick); at most {largest} asks in a tick")
        else:
            print(f"the worker's engine: {decisions} decisions in {ticks} ticks ({decisions / max(ticks, 1):.2f} a tick, "
                  f"at most {largest})")
    if not args.no_profile:
        print(summary(Path(out).read_text()))
        print(f"call tree: {out}")


def engine_stats(log: Path):
    """(ticks, decisions, largest tick[, reads, ticks with a decision]) of the worker's live engine,
    from its last stream log line (None when the log has none)."""
    import json

    found = None
    for line in log.read_text(errors="replace").splitlines():
        i = line.find('{"ts"')
        if i < 0:
            continue
        try:
            rec = json.loads(line[i:])
        except ValueError:
            continue
        if rec.get("event") == "stream" and rec.get("engine"):
            found = tuple(rec["engine"])
    return found


def summary(report: str) -> str:
    """The share of the root's time under each of :data:`PARTS` (a part's functions counted where
    they are outermost on a call path; parts may nest: the Praat reader holds Praat's call)."""
    rows = []
    for line in report.splitlines():
        m = re.match(r"^([\s│├└─]*)(\d+\.\d+)\s+(\S+)", line)
        if m:
            rows.append((len(m.group(1)), float(m.group(2)), m.group(3)))
    if not rows:
        return "(no call tree in the report)"
    total = rows[0][1]
    lines = [f"worker wall time profiled {total:.2f} s (start-up and idle included); each part's share of it and "
             "its time over Praat's own call (the same work in any version: a ratio that a busy machine "
             "inflates less than the seconds)"]
    took_by = {}
    for name, keys in PARTS:
        took, inside = 0.0, None  # depth of the match the current path is in
        for depth, t, fn in rows:
            if inside is not None and depth <= inside:
                inside = None
            if inside is None and any(fn == k or fn.endswith("." + k) for k in keys):
                took += t
                inside = depth
        took_by[name] = took
    praat = took_by[PARTS[0][0]] or float("nan")
    for name, took in took_by.items():
        lines.append(f"  {name:46s} {took:7.2f} s {100 * took / total:5.1f} %  {took / praat:5.2f}x Praat")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
