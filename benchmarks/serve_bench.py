"""``benchmarks/run.py --only serve``: ``headmotion serve`` under load, on loopback, the load
generator on the same cores as the server.

* clients at TTS speed: 30 s of speech in 10 ms (160-sample s16le) messages sent as fast as the
  client can while it reads every frame, one client and eight at once: frames received, whether
  every one equals ``POST /v1/motion``'s for the same samples, and the wall time;
* concurrent paced streams: N clients each send 20 ms chunks of real speech (s16le, 16 kHz) in
  real time to one worker with the shipped streaming model; a frame's latency runs from the send
  of the chunk that completes it (the chunk holding the audio up to the frame's time plus the
  model's lookahead) to its arrival; N grows (:data:`LEVELS`, 1 … 64, the target, in ``--quick``
  too) until the median p95 of :data:`RUNS` runs passes 50 ms or a frame is lost or repeated —
  the largest N that held and the curve, each level with its runs' p95, the machine's free CPU
  just before each run and the cores other programs used during it (above
  :data:`TOO_BUSY_CORES` the level is marked too busy to tell, and a capacity that stopped there
  is not judged), the server's CPU per stream (all its workers, from the processes' CPU times)
  against the model's own stream in-process, the load client's, and one stream's latency and
  first frame — with one worker and with two (one event loop is one core); then past it: a
  server started with ``--max-streams`` at that N gets more clients at once — how many are
  refused with ``busy`` and the p95 of the streams it carries;
* offline: requests per second and p95 latency for 10 s clips with the default model, 1 and 2
  workers, 4 clients at once;
* memory per open stream (server RSS with K streams open, minus before, ÷ K) and memory over a
  long stream (30 minutes of audio sent faster than real time: the RSS at its start and end);
* faults: a client that vanishes mid-stream frees its slot (time until a new stream of the same
  one-stream key is accepted); malformed messages each get one error and a close, the server
  carries on; a worker killed with SIGKILL under load — streams on the other worker go on and
  clients that reconnect get a stream.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
P95_BUDGET_MS = 50.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """``headmotion serve`` in a child process, ready when /readyz says so (``prefix``: the command
    before ``-m headmotion``, e.g. a profiler; ``src``: the package's source folder, default
    ``$SERVE_BENCH_SRC`` or this checkout's)."""

    def __init__(self, *, workers: int = 1, keys: list[tuple] | None = None, max_streams: int | None = None,
                 prefix: list[str] | None = None, src: Path | None = None):
        import httpx

        self.tmp = tempfile.TemporaryDirectory(prefix="hm-serve-bench-")
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        args = [*(prefix or [sys.executable]), "-m", "headmotion", "serve", "--port", str(self.port),
                "--workers", str(workers)]
        if max_streams is not None:
            args += ["--max-streams", str(max_streams)]
        if keys:
            from headmotion.serve.auth import key_line

            kf = Path(self.tmp.name) / "keys.txt"
            kf.write_text("".join(key_line(k, name=n, streams=s, rate=r) + "\n" for k, n, s, r in keys))
            args += ["--api-keys", str(kf)]
        src = src or os.environ.get("SERVE_BENCH_SRC") or ROOT / "src"  # another version's source, to compare
        env = {**os.environ, "PYTHONPATH": str(src) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        self.log = open(Path(self.tmp.name) / "server.log", "w")
        self.proc = subprocess.Popen(args, env=env, stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.time() + 240
        good = 0  # consecutive ready answers: with several workers, each must have loaded its models
        while time.time() < deadline and good < (1 if workers == 1 else 30):
            try:
                ok = httpx.get(self.url + "/readyz", timeout=2).status_code == 200
                good = good + 1 if ok and len(self.workers()) >= workers else 0
            except httpx.HTTPError:
                good = 0
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited: {Path(self.log.name).read_text()[-2000:]}")
            time.sleep(0.3 if good == 0 else 0.05)
        if good == 0:
            raise RuntimeError("server not ready in 240 s")

    def workers(self) -> list:
        """The worker processes (the server process itself with one worker)."""
        import psutil

        me = psutil.Process(self.proc.pid)
        kids = [c for c in me.children() if "resource_tracker" not in " ".join(c.cmdline())]
        return kids or [me]

    def cpu(self) -> float:
        """CPU seconds (user + system) the worker processes have used so far."""
        total = 0.0
        for w in self.workers():
            try:
                t = w.cpu_times()
                total += t.user + t.system
            except Exception:  # noqa: BLE001 - a worker that just ended
                pass
        return total

    def rss(self) -> float:
        import psutil

        procs = [psutil.Process(self.proc.pid), *psutil.Process(self.proc.pid).children(recursive=True)]
        return sum(_rss(p) for p in procs)

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.log.close()
        self.tmp.cleanup()


def _rss(p) -> float:
    try:
        return float(p.memory_info().rss)
    except Exception:  # noqa: BLE001 - a process that just ended
        return 0.0


def speech_pcm(seconds: float, seed: int = 0) -> np.ndarray:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from inputs import speech_audio

    x = speech_audio(seconds, seed).samples
    return (np.clip(x, -1, 1) * 32767).astype("<i2")


class Refused(Exception):
    """The server refused the stream (its error kind)."""


async def paced_stream(url: str, pcm: np.ndarray, *, key: str | None = None, chunk: int = 320, sr: int = 16000,
                       t_start: float | None = None) -> dict:
    """One real-time client: chunks sent at the wall time their last sample would be captured;
    each frame's latency from the send of the chunk that completed it to its arrival."""
    import websockets

    hdr = {"authorization": f"Bearer {key}"} if key else {}
    lat = []
    async with websockets.connect(url.replace("http", "ws") + "/v1/stream", additional_headers=hdr,
                                  max_size=None) as ws:
        try:
            await ws.send(json.dumps({"type": "start", "encoding": "s16le", "frames": "binary", "sample_rate": sr}))
        except websockets.ConnectionClosed:
            pass  # refused at once (busy): its error message is still to be read
        ready = json.loads(await ws.recv())
        if ready["type"] == "error":
            raise Refused(ready["error"])
        lookahead = ready["latency_ms"] / 1000
        fps = ready["fps"]
        t0 = time.perf_counter() if t_start is None else t_start
        n_chunks = len(pcm) // chunk
        sent_at = np.full(n_chunks, np.nan)

        async def send():
            for k in range(n_chunks):
                due = t0 + (k + 1) * chunk / sr
                delay = due - time.perf_counter()
                if delay > 0:
                    await asyncio.sleep(delay)
                await ws.send(pcm[k * chunk:(k + 1) * chunk].tobytes())
                sent_at[k] = time.perf_counter()
            await ws.send(json.dumps({"type": "end"}))

        def completing_chunk(frames: np.ndarray) -> np.ndarray:
            """Index of the chunk whose send made each frame final (the audio up to its time plus
            the lookahead); -1 for frames the tail (end message) makes final."""
            need = np.ceil(np.round((frames / fps + lookahead) * sr, 6))
            k = np.ceil(need / chunk).astype(int) - 1
            return np.where(k < n_chunks, k, -1)

        sender = asyncio.create_task(send())
        end = None
        first_at = []
        try:
            await _read(ws, lat, sent_at, completing_chunk, frames_box := [0, True], first_at)
        finally:
            if not sender.done():
                sender.cancel()
            await asyncio.gather(sender, return_exceptions=True)
        frames, order_ok, end = frames_box[0], frames_box[1], frames_box[2] if len(frames_box) > 2 else None
    # the first frame: from the send of the chunk that completes frame 0 to its arrival
    k0 = int(completing_chunk(np.array([0]))[0])
    first = first_at[0] - sent_at[k0] if first_at and k0 >= 0 and not np.isnan(sent_at[k0]) else np.nan
    return {"lat": lat, "frames": frames, "fps": fps, "first": first,
            "ok": order_ok and end is not None and end["frames"] == frames}


async def _read(ws, lat, sent_at, completing_chunk, box, first_at) -> None:
    """Frames of one paced stream: count, order and latency into ``lat``; ``box`` = [frames, in
    order, end message]; ``first_at``: the arrival time of the first frames message."""
    async for msg in ws:
        now = time.perf_counter()
        if isinstance(msg, bytes):
            if not first_at:
                first_at.append(now)
            first, n = int.from_bytes(msg[4:8], "little"), int.from_bytes(msg[8:12], "little")
            box[1] &= first == box[0]
            box[0] += n
            k = completing_chunk(first + np.arange(n))
            k = k[k >= 0]  # frames made final by a paced chunk (not by the end message)
            if len(k):
                last_sent = int(np.flatnonzero(~np.isnan(sent_at))[-1]) if np.any(~np.isnan(sent_at)) else 0
                lat.extend(now - sent_at[np.minimum(k, last_sent)])
        else:
            d = json.loads(msg)
            if d["type"] == "end":
                box.append(d)
            elif d["type"] == "error":
                raise RuntimeError(d)


def stream_level(srv: "Server", n: int, seconds: float, pcm_pool) -> dict:
    """N paced streams at once (their chunk times spread over one chunk period, as independent
    clients are): p50/p95 latency, whether every admitted stream got every frame, streams refused,
    the server's CPU (all its workers) and this client's per stream."""
    async def main():
        t0 = time.perf_counter() + 0.5
        jobs = [paced_stream(srv.url, pcm_pool[k % len(pcm_pool)], t_start=t0 + 0.02 * k / n) for k in range(n)]
        return await asyncio.gather(*jobs, return_exceptions=True)

    import psutil

    cpu0, mine0, sys0, wall0 = srv.cpu(), time.process_time(), _busy_cpu(psutil.cpu_times()), time.perf_counter()
    res = asyncio.run(main())
    cpu, mine = srv.cpu() - cpu0, time.process_time() - mine0
    wall = time.perf_counter() - wall0
    others = max(0.0, _busy_cpu(psutil.cpu_times()) - sys0 - cpu - mine) / wall  # cores other programs used
    refused = [r for r in res if isinstance(r, Refused)]
    errs = [r for r in res if isinstance(r, BaseException) and not isinstance(r, Refused)]
    ok = [r for r in res if not isinstance(r, BaseException)]
    lat = np.concatenate([r["lat"] for r in ok]) * 1000 if ok else np.array([np.inf])
    # every frame at the model's rate (the ready message's fps)
    complete = all(r["ok"] and abs(r["frames"] - round(seconds * r["fps"])) <= 1 for r in ok) and not errs
    first = [r["first"] for r in ok if np.isfinite(r["first"])]
    return {"n": n, "p50": float(np.percentile(lat, 50)), "p95": float(np.percentile(lat, 95)),
            "complete": complete, "errors": [repr(e)[:100] for e in errs][:3],
            "refused": [r.args[0] for r in refused], "carried": len(ok),
            "cpu_per_stream_s": cpu / (max(1, len(ok)) * seconds),
            "client_cpu_per_stream_s": mine / (max(1, len(ok)) * seconds),
            "first_ms": float(np.median(first) * 1000) if first else float("nan"),
            "others_cores": others, "load": os.getloadavg()[0]}


def _busy_cpu(t) -> float:
    """CPU seconds the whole machine has been busy (all cores; not idle, not waiting for I/O)."""
    return sum(t) - t.idle - getattr(t, "iowait", 0.0) - getattr(t, "guest", 0.0) - getattr(t, "guest_nice", 0.0)


def free_cpu(seconds: float = 1.0) -> float:
    """Cores free on the machine over the next ``seconds`` (nothing of ours running)."""
    import psutil

    t0, w0 = _busy_cpu(psutil.cpu_times()), time.perf_counter()
    time.sleep(seconds)
    busy = (_busy_cpu(psutil.cpu_times()) - t0) / (time.perf_counter() - w0)
    return max(0.0, (os.cpu_count() or 1) - busy)


def model_cpu_per_second(pcm: np.ndarray, chunk: int = 320, sr: int = 16000) -> float:
    """CPU seconds per second of audio of the shipped stream model's own stream in this process
    (the library's stream, 20 ms pushes): what a server stream costs at the least."""
    from threadpoolctl import threadpool_limits

    from headmotion.synthesis import load_model, open_stream

    x = pcm.astype(np.float32) / 32768.0
    model = load_model("stream")
    best = np.inf
    with threadpool_limits(limits=1, user_api="blas"):  # as a serve worker runs it
        for _ in range(3):
            s = open_stream(model, seed=0)
            t0 = time.process_time()
            for i in range(0, len(x), chunk):
                s.push(x[i:i + chunk])
            s.flush()
            best = min(best, time.process_time() - t0)
    return best / (len(x) / sr)


def bench_tts_speed(res, Row, _quick: bool) -> None:
    """30 s of speech in 160-sample messages as fast as the client sends, reading every frame: one
    client, then eight at once; every frame compared with POST /v1/motion's for the same samples."""
    import httpx

    seconds = 30.0
    pcms = [speech_pcm(seconds, seed=10 + k) for k in range(8)]
    srv = Server()
    try:
        def offline(pcm):
            r = httpx.post(srv.url + "/v1/motion", params={"model": "stream", "format": "npz", "encoding": "s16le",
                                                           "sample_rate": 16000}, content=pcm.tobytes(), timeout=600)
            r.raise_for_status()
            with np.load(__import__("io").BytesIO(r.content)) as z:
                return next(z[k] for k in z.files if z[k].ndim == 2 and z[k].shape[1] == 3)

        wants = [offline(p) for p in pcms]
        for n in (1, 8):
            async def main(n=n):
                return await asyncio.gather(*[unpaced_stream(srv.url, pcms[k]) for k in range(n)],
                                            return_exceptions=True)

            t0 = time.perf_counter()
            out = asyncio.run(main())
            wall = time.perf_counter() - t0
            good = [not isinstance(o, BaseException) and o.shape == wants[k].shape
                    and float(np.abs(o - wants[k]).max()) <= 1e-6 for k, o in enumerate(out)]
            frames = sum(len(o) for o in out if not isinstance(o, BaseException))
            errs = [repr(o)[:80] for o in out if isinstance(o, BaseException)]
            res.add(Row("10 serve", f"{n} client{'s' if n > 1 else ''} at TTS speed (30 s of speech in 10 ms "
                                    f"messages, unpaced, every frame read): streams with every frame equal to POST's",
                        sum(good), f"of {n}", f"{n}", all(good),
                        f"{frames} of {n * len(wants[0])} frames; {wall:.1f} s wall for {n * seconds:.0f} s of audio "
                        f"({n * seconds / wall:.0f}x real time); {'; '.join(errs[:2]) or 'no error'}"))
    finally:
        srv.stop()


async def unpaced_stream(url: str, pcm: np.ndarray, chunk: int = 160) -> np.ndarray:
    """One client sending ``chunk``-sample messages as fast as it can while reading every frame:
    the frames' rotation vectors."""
    import websockets

    async with websockets.connect(url.replace("http", "ws") + "/v1/stream", max_size=None) as ws:
        await ws.send(json.dumps({"type": "start", "encoding": "s16le", "frames": "binary", "sample_rate": 16000}))
        json.loads(await ws.recv())

        async def feed():
            for i in range(0, len(pcm), chunk):
                await ws.send(pcm[i:i + chunk].tobytes())
            await ws.send(json.dumps({"type": "end"}))

        sender = asyncio.create_task(feed())
        rows = []
        async for msg in ws:
            if isinstance(msg, bytes):
                rows.append(np.frombuffer(msg, "<f4", offset=24).reshape(-1, 6)[:, :3])
            else:
                d = json.loads(msg)
                if d["type"] == "error":
                    raise RuntimeError(f"{d['error']} after {sum(len(r) for r in rows)} frames")
        await sender
    return np.vstack(rows)


#: the stream counts tried, up to the target
LEVELS = (1, 2, 4, 8, 12, 16, 20, 24, 32, 40, 48, 56, 64)
TARGET_STREAMS = 64
#: runs per level (the median is reported)
RUNS = 3
#: other programs using more than this many cores during a level: too busy to tell
TOO_BUSY_CORES = 0.5
#: the server's CPU per stream may be this many times the model's own stream's
CPU_RATIO_TARGET = 1.5


def _level(srv, n: int, seconds: float, pool, runs: int) -> dict:
    """``runs`` runs of N paced streams: the median of each figure, each run's p95, the free CPU
    measured just before each run and the cores other programs used during it."""
    rs = []
    for _ in range(runs):
        free = free_cpu(0.5)
        r = stream_level(srv, n, seconds, pool)
        r["free_before"] = free
        rs.append(r)

    def med(k):
        return float(np.median([r[k] for r in rs]))

    out = {k: med(k) for k in ("p50", "p95", "cpu_per_stream_s", "client_cpu_per_stream_s", "first_ms",
                               "others_cores", "free_before", "load")}
    out.update(n=n, complete=all(r["complete"] for r in rs), p95_runs=[r["p95"] for r in rs],
               carried=min(r["carried"] for r in rs), errors=[e for r in rs for e in r["errors"]][:3],
               too_busy=out["others_cores"] > TOO_BUSY_CORES)
    return out


def _capacity(workers: int, seconds: float, pool, runs: int) -> tuple[int, list]:
    """The curve of paced streams on ``workers`` worker processes: N grows up to
    :data:`TARGET_STREAMS` until the median p95 passes 50 ms or a frame is lost; the largest N
    that held and the levels."""
    srv = Server(workers=workers)
    curve, best = [], 0
    try:
        for n in LEVELS:
            r = _level(srv, n, seconds, pool, runs)
            curve.append(r)
            if r["p95"] > P95_BUDGET_MS or not r["complete"]:
                break
            best = n
    finally:
        srv.stop()
    return best, curve


def _level_note(r: dict) -> str:
    busy = "; too busy to tell" if r["too_busy"] else ""
    lost = "" if r["complete"] else ", frames lost"
    runs = "/".join(f"{p:.0f}" for p in r["p95_runs"])
    return (f"{r['n']}: {r['p95']:.0f} ms (runs {runs}{lost}; free CPU before {r['free_before']:.1f} cores, others "
            f"{r['others_cores']:.1f} cores during, load {r['load']:.1f}{busy})")


def bench_streams(res, Row, quick: bool) -> None:
    seconds = 5.0 if quick else 10.0
    pool = [speech_pcm(seconds, seed=s) for s in range(4)]
    model_cpu = model_cpu_per_second(pool[0])
    best1 = 0
    for workers in (1, 2):
        best, curve = _capacity(workers, seconds, pool, RUNS)
        best1 = best if workers == 1 else best1
        held = [r for r in curve if r["n"] <= max(best, 1)]
        at = held[-1]
        cpu, client = at["cpu_per_stream_s"], at["client_cpu_per_stream_s"]
        stop = curve[-1] if curve[-1]["n"] > best else None
        unsure = stop is not None and stop["too_busy"]
        verdict = None if unsure and best < TARGET_STREAMS else best >= TARGET_STREAMS
        why = ("" if stop is None else
               f"; stopped at N={stop['n']}" + (" with the machine too busy to tell (other programs used "
                                                 f"{stop['others_cores']:.1f} cores)" if unsure else ""))
        res.add(Row("10 serve", f"paced real-time streams (20 ms chunks, {seconds:g} s of speech each), {workers} "
                                f"worker{'s' if workers > 1 else ''}, largest N with the median p95 of {RUNS} runs "
                                "<= 50 ms from the chunk completing a frame to the frame, no frame lost",
                    best, "streams", f">= {TARGET_STREAMS} on 2 cores", verdict,
                    f"median p95 by N: {'; '.join(_level_note(r) for r in curve)}{why}. At N={at['n']} server CPU "
                    f"{cpu * 100:.2f}% of a core per stream, {cpu / model_cpu:.2f}x the model's own stream "
                    f"({model_cpu * 100:.2f}% of a core in-process, one BLAS thread; target <= {CPU_RATIO_TARGET:g}x); "
                    f"the load client on the same cores {client * 100:.2f}% of a core per stream"))
        one = curve[0]
        res.add(Row("10 serve", f"one paced stream, {workers} worker{'s' if workers > 1 else ''}: p50 / p95 latency "
                                f"and first frame (median of {RUNS} runs)", one["p95"], "ms p95", "-", None,
                    f"p50 {one['p50']:.1f} ms, p95 {one['p95']:.1f} ms, first frame {one['first_ms']:.1f} ms after "
                    f"the chunk completing it; load {one['load']:.1f}"))
        res.add(Row("10 serve", f"server CPU per stream at N={at['n']}, {workers} worker{'s' if workers > 1 else ''}, "
                                "over the model's own stream in-process", cpu / model_cpu, "x",
                    f"<= {CPU_RATIO_TARGET:g}x", None if at["too_busy"] else cpu / model_cpu <= CPU_RATIO_TARGET,
                    f"{cpu * 100:.2f}% against {model_cpu * 100:.2f}% of a core; load {at['load']:.1f}"
                    + ("; too busy to tell" if at["too_busy"] else "")))
    if best1 < 1:
        return
    best = best1
    extra = max(2, best // 2)
    srv = Server(max_streams=best)  # past it: the server refuses what it cannot carry
    try:
        r = stream_level(srv, best + extra, seconds, pool)
    finally:
        srv.stop()
    busy = sum(k == "busy" for k in r["refused"])
    ok = busy == extra and r["carried"] == best and r["complete"] and r["p95"] <= P95_BUDGET_MS
    res.add(Row("10 serve", f"past it: {best + extra} paced streams at once to a worker started with "
                            f"--max-streams {best}: streams refused with busy", busy, f"of {extra} extra",
                f"{extra}", ok,
                f"{r['carried']} carried with every frame: {r['complete']}, p50 {r['p50']:.0f} ms, p95 "
                f"{r['p95']:.0f} ms; refused: {r['refused']}; load {r['load']:.1f}"))


def bench_offline(res, Row, quick: bool) -> None:
    import concurrent.futures as cf
    import io

    import httpx
    import soundfile as sf

    buf = io.BytesIO()
    sf.write(buf, speech_pcm(10.0, seed=7), 16000, format="WAV", subtype="PCM_16")
    body = buf.getvalue()
    n_req = 8 if quick else 24
    for workers in (1, 2):
        srv = Server(workers=workers)
        try:
            def one(_, url=srv.url):
                t = time.perf_counter()
                r = httpx.post(url + "/v1/motion", content=body, headers={"content-type": "audio/wav"}, timeout=300)
                assert r.status_code == 200, r.text[:200]
                return time.perf_counter() - t

            one(0)  # warm-up
            t0 = time.perf_counter()
            with cf.ThreadPoolExecutor(4) as ex:
                lat = list(ex.map(one, range(n_req)))
            wall = time.perf_counter() - t0
        finally:
            srv.stop()
        res.add(Row("10 serve", f"offline 10 s clips, default model, {workers} worker{'s' if workers > 1 else ''}, "
                                f"4 clients: requests/s", n_req / wall, "req/s", "-", None,
                    f"{n_req} requests; p50 {np.percentile(lat, 50) * 1000:.0f} ms"))
        res.add(Row("10 serve", f"offline 10 s clips, {workers} worker{'s' if workers > 1 else ''}: p95 latency",
                    float(np.percentile(lat, 95) * 1000), "ms", "-", None, "4 requests in flight at a time"))


def bench_memory(res, Row, quick: bool) -> None:
    import websockets

    k = 20 if quick else 50
    long_s = 300.0 if quick else 1800.0
    srv = Server()
    try:
        async def hold():
            url = srv.url.replace("http", "ws") + "/v1/stream"
            socks = []
            pcm = speech_pcm(1.0).tobytes()
            base = srv.rss()
            for _ in range(k):
                ws = await websockets.connect(url, max_size=None)
                await ws.send(json.dumps({"type": "start", "encoding": "s16le", "frames": "binary"}))
                await ws.recv()
                for i in range(0, len(pcm), 3200):
                    await ws.send(pcm[i:i + 3200])
                socks.append(ws)
            await asyncio.sleep(1.0)
            per = (srv.rss() - base) / k
            for ws in socks:
                await ws.close()
            return per, base

        per, base = asyncio.run(hold())
        res.add(Row("10 serve", f"memory per open stream ({k} streams, 1 s of audio each)", per / 1e6, "MB", "-", None,
                    f"server RSS {base / 1e6:.0f} MB before"))

        async def long_stream():
            url = srv.url.replace("http", "ws") + "/v1/stream"
            samples = []
            pcm = speech_pcm(60.0, seed=3).tobytes()
            async with websockets.connect(url, max_size=None) as ws:
                await ws.send(json.dumps({"type": "start", "encoding": "s16le", "frames": "binary"}))
                await ws.recv()

                async def drain():
                    async for _ in ws:
                        pass

                reader = asyncio.create_task(drain())
                t0 = time.perf_counter()
                for _minute in range(int(long_s // 60)):
                    for i in range(0, len(pcm), 3200):
                        await ws.send(pcm[i:i + 3200])
                    samples.append(srv.rss())
                await ws.send(json.dumps({"type": "end"}))
                await reader
                return samples, time.perf_counter() - t0

        rss, wall = asyncio.run(long_stream())
        res.add(Row("10 serve", f"memory over one stream of {long_s / 60:.0f} min of audio (sent faster than real time)",
                    (rss[-1] - rss[0]) / 1e6, "MB growth", "<= 20 MB", (rss[-1] - rss[0]) / 1e6 <= 20,
                    f"server RSS after minute 1 {rss[0] / 1e6:.0f} MB, after the last {rss[-1] / 1e6:.0f} MB, "
                    f"max {max(rss) / 1e6:.0f} MB; {wall:.0f} s wall"))
    finally:
        srv.stop()


def bench_faults(res, Row, _quick: bool) -> None:
    import httpx
    import websockets

    srv = Server(keys=[("k-one", "one", 1, 6000)])
    hdr = {"authorization": "Bearer k-one"}
    url = srv.url.replace("http", "ws") + "/v1/stream"
    try:
        async def vanish():
            ws = await websockets.connect(url, additional_headers=hdr)
            await ws.send(json.dumps({"type": "start", "encoding": "s16le"}))
            await ws.recv()
            await ws.send(speech_pcm(1.0).tobytes())
            ws.transport.abort()  # the client vanishes: no close frame
            t0 = time.perf_counter()
            while True:
                async with websockets.connect(url, additional_headers=hdr) as ws2:
                    await ws2.send(json.dumps({"type": "start"}))
                    d = json.loads(await ws2.recv())
                    if d["type"] == "ready":
                        return time.perf_counter() - t0
                await asyncio.sleep(0.005)

        dt = asyncio.run(vanish())
        res.add(Row("10 serve", "a client vanishing mid-stream frees its slot (one-stream key: time until a "
                                "new stream is accepted)", dt * 1000, "ms", "<= 1000 ms", dt <= 1.0, "TCP abort, no close frame"))

        bad = [("binary first", [b"\x00\x00"]), ("wrong first message", ['{"type":"hello"}']),
               ("odd byte count", ['{"type":"start"}', b"\x00\x01\x02"]),
               ("huge frame", ['{"type":"start"}', b"\x00" * (2 * 1024 * 1024)]),
               ("text where binary is due", ['{"type":"start"}', "audio"]),
               ("unknown model", ['{"type":"start","model":"nope"}'])]

        async def malformed():
            out = []
            for name, msgs in bad:
                async with websockets.connect(url, additional_headers=hdr, max_size=None) as ws:
                    for m in msgs:
                        await ws.send(m)
                    got = await _all_messages(ws)
                    errs = [json.loads(m) for m in got if isinstance(m, str) and '"error"' in m]
                    out.append((name, len(errs) == 1, ws.close_code, errs[0]["error"] if errs else None))
            async with websockets.connect(url, additional_headers={"authorization": "Bearer bad"}) as ws:
                try:  # the key is checked on the handshake: the error and the close may come first
                    await ws.send('{"type":"start"}')
                except websockets.ConnectionClosed:
                    pass
                got = await _all_messages(ws)
                out.append(("bad key", len(got) == 1, ws.close_code, json.loads(got[0])["error"]))
            return out

        out = asyncio.run(malformed())
        alive = httpx.get(srv.url + "/readyz").status_code == 200
        ok = all(o[1] for o in out) and alive
        res.add(Row("10 serve", "malformed messages: one error and a close each, server carries on", sum(o[1] for o in out),
                    f"of {len(out)}", "all", ok, "; ".join(f"{n}: {k} ({c})" for n, _, c, k in out)))
    finally:
        srv.stop()
    _kill_worker(res, Row)


async def _all_messages(ws) -> list:
    """Every message until the server closes, whatever the close code."""
    import websockets

    got = []
    try:
        async for m in ws:
            got.append(m)
    except websockets.ConnectionClosed:
        pass
    return got


def _kill_worker(res, Row) -> None:
    """Two workers, 6 paced streams; one worker gets SIGKILL; clients whose stream broke reconnect."""
    srv = Server(workers=2)
    try:
        pool = [speech_pcm(8.0, seed=s) for s in range(2)]

        async def client(k):
            broken, tries = 0, 0
            while tries < 20:
                tries += 1
                try:
                    r = await paced_stream(srv.url, pool[k % 2])
                    return {"broken": broken, "ok": r["ok"]}
                except Exception:  # noqa: BLE001 - the stream broke with its worker: reconnect
                    broken += 1
                    await asyncio.sleep(0.2)
            return {"broken": broken, "ok": False}

        async def main():
            tasks = [asyncio.create_task(client(k)) for k in range(6)]
            await asyncio.sleep(3.0)
            victim = srv.workers()[0]
            os.kill(victim.pid, signal.SIGKILL)
            return await asyncio.gather(*tasks)

        out = asyncio.run(main())
        broken = sum(o["broken"] > 0 for o in out)
        ok = all(o["ok"] for o in out)
        res.add(Row("10 serve", "a worker killed (SIGKILL) under load, 2 workers, 6 paced streams: streams "
                                "completed after reconnecting", sum(o["ok"] for o in out), "of 6", "6", ok,
                    f"{broken} of 6 streams were on the killed worker (uvicorn's workers share one socket and "
                    f"the kernel need not spread connections evenly); each reconnected and was served in full"))
    finally:
        srv.stop()


def bench_serve(res, quick: bool) -> None:
    """The ``serve`` group of benchmarks/run.py."""
    from harness import Row

    for part in (bench_tts_speed, bench_streams, bench_offline, bench_memory, bench_faults):
        try:
            part(res, Row, quick)
        except Exception as exc:  # noqa: BLE001 - one failing part must not hide the others
            res.add(Row("10 serve", part.__name__, None, "", "", False, f"error: {type(exc).__name__}: {exc}"[:200]))


__all__ = ["bench_serve", "Server", "paced_stream"]
