"""Load driver for the listening-test server: simulated participants over HTTP.

``headmotion listen serve`` runs in its own process group (``--workers N``); each simulated
participant registers, answers the demographics, starts, then loops *read the state → answer →
wait ``think_s``* until done, exactly as the browser page does.  Every acknowledged answer is
recorded so that the database can be checked afterwards (stored once, with the value sent), and
the answer POST's response time is recorded for the p95.

Used by ``benchmarks/run.py --only server`` and by ``tests/test_listening_hardening.py``.
The test is a MUSHRA test made from the package's example stimuli (``examples/listening``),
``n_items`` items long (three of the example items repeated under new ids).
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ADMIN = "bench-admin-token"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def make_test_dir(dst: Path, *, n_items: int = 12, per_address: int = 100_000,
                  max_participants: int | None = None) -> Path:
    """A copy of ``examples/listening`` with ``load.yaml``: a MUSHRA test of ``n_items`` items."""
    shutil.copytree(ROOT / "examples" / "listening", dst, ignore=shutil.ignore_patterns("results"))
    lines = ["type: mushra", "name: load", "title: load test", "seed: 1",
             f"registrations_per_address: {per_address}"]
    if max_participants is not None:
        lines.append(f"max_participants: {max_participants}")
    lines += ["demographics:", "  - name: native_language", "    label: Native?", '    options: ["yes", "no"]',
              "mushra:", "  hidden_reference: reference", "  anchor: noise", "items:"]
    for k in range(n_items):
        s = f"s{k % 3 + 1}"
        lines += [f"  - id: item{k}", f"    speaker: {'AB'[k % 2]}",
                  f"    reference: {{motion: motion/{s}_natural.npz, audio: audio/{s}.wav}}",
                  "    conditions:"]
        conds = {"reference": "natural", "system": "system", "desync": "desync", "noise": "noise"}
        for c, f in conds.items():
            lines.append(f"      {c}: {{motion: motion/{s}_{f}.npz, audio: audio/{s}.wav}}")
    (dst / "load.yaml").write_text("\n".join(lines) + "\n")
    return dst / "load.yaml"


class ServerProc:
    """``headmotion listen serve`` in its own process group."""

    def __init__(self, config: Path, database: str, *, workers: int = 1, port: int | None = None,
                 extra: tuple[str, ...] = (), sync: str = "full"):
        self.config, self.database, self.workers, self.extra = config, database, workers, extra
        self.sync = sync
        self.port = port or free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.start()

    def start(self):
        import httpx

        env = dict(os.environ)
        env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
        # the server's stderr goes to a file, not a pipe: a pipe nobody reads fills up when the
        # server logs errors under load, and every worker then blocks in its logger
        import tempfile

        self.log = tempfile.TemporaryFile()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "headmotion", "listen", "serve", str(self.config), "--port", str(self.port),
             "--database", self.database, "--admin-token", ADMIN, "--workers", str(self.workers), "--sync", self.sync, *self.extra],
            stdout=subprocess.DEVNULL, stderr=self.log, start_new_session=True, env=env)
        deadline = time.time() + 120
        ok = 0
        while time.time() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server died: {self.stderr_tail()}")
            try:
                if httpx.get(self.url + "/api/test", timeout=2).status_code == 200:
                    ok += 1
                    if ok >= 2 * self.workers:  # every worker has had a chance to start
                        return
                    continue
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        raise RuntimeError("server did not start")

    def stderr_tail(self, n: int = 2000) -> str:
        """The end of what the server wrote to stderr (errors it logged)."""
        self.log.flush()
        self.log.seek(0)
        return self.log.read().decode(errors="replace")[-n:]

    def cpu_seconds(self) -> float:
        """CPU time (user + system) used so far by the server's processes (master and workers)."""
        import psutil

        try:
            root = psutil.Process(self.proc.pid)
            procs = [root] + root.children(recursive=True)
        except psutil.Error:
            return float("nan")
        total = 0.0
        for p in procs:
            try:
                t = p.cpu_times()
                total += t.user + t.system
            except psutil.Error:
                pass
        return total

    def kill(self):
        """SIGKILL the whole server (the master and every worker)."""
        os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait(10)

    def stop(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)

    def answers(self) -> list[dict]:
        import httpx

        r = httpx.get(self.url + "/api/admin/results.json", headers={"Authorization": f"Bearer {ADMIN}"},
                      timeout=120)
        r.raise_for_status()
        return r.json()["answers"]


def answer_for(trial: dict, pnum: int) -> dict:
    """A deterministic answer of participant ``pnum`` to ``trial``."""
    i = trial["index"]
    if trial["kind"] == "attention":
        return {"choice": trial["options"][(pnum + i) % len(trial["options"])]}
    if trial["kind"] == "mos":
        return {"rating": 1 + (pnum * 7 + i * 3) % 7}
    if trial["kind"] == "mushra":
        return {"ratings": {s["label"]: float((pnum * 13 + i * 7 + k * 29) % 101)
                            for k, s in enumerate(trial["slots"])}}
    return {"choice": "left" if (pnum + i) % 2 else "right"}


class NoResponse(Exception):
    """The server did not answer a request in time (an error, unlike a closed connection)."""


class _Conn(asyncio.Protocol):
    """One keep-alive HTTP/1.1 connection, one request at a time (as a browser tab's fetches):
    requests written by hand, responses parsed by ``httptools`` (the parser uvicorn uses).

    httpx spent ~4 ms of CPU per request in this client, more than the server under test, on the
    same two cores; this costs tens of microseconds, so the figures measure the server."""

    def __init__(self, host: str):
        import httptools

        self.host = host.encode()
        self.transport = None
        self.parser = httptools.HttpResponseParser(self)
        self.waiter: asyncio.Future | None = None
        self.body: list[bytes] = []
        self.lost: BaseException | None = None

    @classmethod
    async def open(cls, url: str) -> "_Conn":
        hostport = url.split("://", 1)[1].rstrip("/")
        host, port = hostport.rsplit(":", 1)
        loop = asyncio.get_running_loop()
        _t, conn = await loop.create_connection(lambda: cls(hostport), host, int(port))
        return conn

    # asyncio.Protocol
    def connection_made(self, transport):
        self.transport = transport

    def data_received(self, data):
        try:
            self.parser.feed_data(data)
        except Exception as exc:  # noqa: BLE001 - a garbled response fails the request
            self._fail(ConnectionError(f"bad response: {exc}"))

    def connection_lost(self, exc):
        self.lost = exc or ConnectionError("connection closed")
        self._fail(ConnectionError(f"connection lost: {self.lost}"))

    def _fail(self, exc):
        if self.waiter is not None and not self.waiter.done():
            self.waiter.set_exception(exc)

    # httptools callbacks
    def on_body(self, body: bytes):
        self.body.append(body)

    def on_message_complete(self):
        if self.waiter is not None and not self.waiter.done():
            self.waiter.set_result((self.parser.get_status_code(), b"".join(self.body)))

    async def request(self, method: str, path: str, payload=None, timeout_s: float = 120.0) -> tuple[int, bytes]:
        """``(status, body)``; ``ConnectionError`` when the server goes away, :class:`NoResponse`
        when it does not answer within ``timeout_s``."""
        if self.lost is not None:
            raise ConnectionError("connection closed")
        body = b"" if payload is None else json.dumps(payload).encode()
        self.body = []
        loop = asyncio.get_running_loop()
        self.waiter = loop.create_future()
        head = (f"{method} {path} HTTP/1.1\r\nHost: ").encode() + self.host + \
            b"\r\nContent-Type: application/json\r\nContent-Length: " + str(len(body)).encode() + b"\r\n\r\n"
        self.transport.write(head + body)
        timer = loop.call_later(timeout_s, self._fail, NoResponse(f"{method} {path}: no response in {timeout_s:g} s"))
        try:
            return await self.waiter
        finally:
            timer.cancel()

    def close(self):
        if self.transport is not None:
            self.transport.close()


async def participant(url: str, pnum: int, *, think_s: float, sent: dict, latencies: list, errors: list,
                      registered: dict, started: set | None = None):
    """One simulated participant on its own keep-alive connection, as a browser tab: register,
    demographics, start, then *state → answer → wait think_s* until done.  Acknowledged answers go
    to ``sent``; a dropped connection (the server killed) ends the participant quietly."""
    conn = None
    try:
        conn = await _Conn.open(url)
        status, body = await conn.request("POST", "/api/participants", {"consent": True})
        if status != 201:
            errors.append((pnum, "register", status, body[:200]))
            return
        token = json.loads(body)["token"]
        registered[pnum] = token
        status, body = await conn.request("POST", f"/api/p/{token}/demographics",
                                          {"answers": {"native_language": "yes"}})
        if status != 200:
            errors.append((pnum, "demographics", status, body[:200]))
            return
        status, body = await conn.request("POST", f"/api/p/{token}/start")
        if status != 200:
            errors.append((pnum, "start", status, body[:200]))
            return
        if started is not None:
            started.add(pnum)
        while True:
            status, body = await conn.request("GET", f"/api/p/{token}/state")
            if status != 200:
                errors.append((pnum, "state", status, body[:200]))
                return
            st = json.loads(body)
            if st["stage"] == "done":
                return
            trial = st["trial"]
            answer = {"trial_index": trial["index"], **answer_for(trial, pnum)}
            t0 = time.perf_counter()
            status, body = await conn.request("POST", f"/api/p/{token}/answer", answer)
            latencies.append(time.perf_counter() - t0)
            if status != 200:
                errors.append((pnum, "answer", status, body[:200]))
                return
            sent[(token, trial["index"])] = answer
            await asyncio.sleep(think_s)
    except NoResponse as exc:
        errors.append((pnum, "timeout", None, str(exc)))
    except OSError:  # refused / reset / closed: the server was killed
        return
    finally:
        if conn is not None:
            conn.close()


async def run_panel(url: str, n: int, *, think_s: float = 0.05, sent=None, latencies=None, errors=None,
                    registered=None, ramp_s: float = 1.0, started=None):
    sent = {} if sent is None else sent
    latencies = [] if latencies is None else latencies
    errors = [] if errors is None else errors
    registered = {} if registered is None else registered

    async def one(p):
        await asyncio.sleep(ramp_s * p / max(n, 1))  # participants arrive over ramp_s seconds
        await participant(url, p, think_s=think_s, sent=sent, latencies=latencies, errors=errors,
                          registered=registered, started=started)

    await asyncio.gather(*(one(p) for p in range(n)))
    return sent, latencies, errors, registered


def _run(coro):
    """``asyncio.run`` on uvloop when it is installed (cheaper for the client, which shares the
    cores with the server under test)."""
    try:
        import uvloop
    except ImportError:
        return asyncio.run(coro)
    with asyncio.Runner(loop_factory=uvloop.new_event_loop) as runner:
        return runner.run(coro)


def load(url: str, n: int, *, think_s: float = 0.05, server: ServerProc | None = None) -> dict:
    """Run ``n`` participants to the end; figures and what was acknowledged.

    With ``server``, also the server's CPU time (all its processes) per answer — a figure that
    does not depend on what else the machine is doing: ``server_cpu_ms_per_answer`` over the whole
    run (registration, demographics and start included) and ``steady_cpu_ms_per_answer`` from the
    moment the last participant has started (state reads and answers only).
    ``client_cpu_ms_per_answer`` is this process's own CPU over the run (the load client shares
    the machine's cores)."""
    import numpy as np

    sent: dict = {}
    lat: list = []
    errors: list = []
    registered: dict = {}
    started: set = set()
    mark: dict = {}

    async def main():
        task = asyncio.ensure_future(run_panel(url, n, think_s=think_s, sent=sent, latencies=lat,
                                               errors=errors, registered=registered, started=started))
        while len(started) < n and not task.done():
            await asyncio.sleep(0.005)
        mark.update(answers=len(sent), cpu=server.cpu_seconds() if server is not None else float("nan"))
        await task

    cpu0 = server.cpu_seconds() if server is not None else float("nan")
    own0 = time.process_time()
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    _run(main())
    elapsed = time.perf_counter() - t0
    own = time.process_time() - own0
    cpu1 = server.cpu_seconds() if server is not None else float("nan")
    lat_ms = np.array(lat) * 1000
    steady = len(sent) - mark.get("answers", 0)
    return {"participants": n, "answers": len(sent), "seconds": elapsed, "answers_per_s": len(sent) / elapsed,
            "server_cpu_ms_per_answer": 1000 * (cpu1 - cpu0) / max(len(sent), 1),
            "steady_cpu_ms_per_answer": 1000 * (cpu1 - mark.get("cpu", float("nan"))) / max(steady, 1),
            "client_cpu_ms_per_answer": 1000 * own / max(len(sent), 1),
            "p50_ms": float(np.percentile(lat_ms, 50)) if len(lat_ms) else float("nan"),
            "p95_ms": float(np.percentile(lat_ms, 95)) if len(lat_ms) else float("nan"),
            "load_before": load0, "load_after": os.getloadavg()[0],
            "errors": errors, "sent": sent, "registered": registered}


def check_stored(answers: list[dict], sent: dict, pid_by_token: dict) -> None:
    """Every acknowledged answer is stored exactly once with the values sent, and nothing else
    is: each participant's stored trials are 0, 1, ... k-1 with k at most one more than it had
    acknowledged (the answer in flight when the server died may or may not have been committed)."""
    keys = [(a["participant"], a["trial_index"], a["slot"]) for a in answers]
    assert len(keys) == len(set(keys)), "an answer was stored twice"
    stored = {(a["participant"], a["trial_index"], a["slot"]): a for a in answers}
    for (token, idx), body in sent.items():
        pid = pid_by_token[token]
        for lab, v in body["ratings"].items():
            assert stored[(pid, idx, lab)]["value"] == v, (token, idx, lab)
    acked: dict[int, int] = {}
    for token, _idx in sent:
        acked[pid_by_token[token]] = acked.get(pid_by_token[token], 0) + 1
    trials: dict[int, set] = {}
    for a in answers:
        trials.setdefault(a["participant"], set()).add(a["trial_index"])
    for pid, got in trials.items():
        assert got == set(range(len(got))), f"participant {pid}: stored trials {sorted(got)} have a gap"
        assert len(got) <= acked.get(pid, 0) + 1, \
            f"participant {pid}: {len(got)} trials stored, {acked.get(pid, 0)} acknowledged"


def pid_by_token(db_url: str) -> dict:
    import sqlalchemy as sa

    sys.path.insert(0, str(ROOT / "src"))
    from headmotion.listening.db import participants

    eng = sa.create_engine(db_url)
    with eng.connect() as c:
        out = {r.token: r.id for r in c.execute(sa.select(participants.c.token, participants.c.id))}
    eng.dispose()
    return out
