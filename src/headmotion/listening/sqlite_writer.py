"""Group commit for the listening-test database on SQLite: one writer thread per server process.

The seeds are silent on storage; the server must keep an answer POST's p95 under 250 ms
with 300 participants answering every 50 ms, and an answer must be durable once acknowledged.
With one transaction per answer, every answer pays a commit — an fsync under
``synchronous=FULL`` — and answers queue behind each other's fsyncs.  Here request handlers hand
their write to one thread that owns the process's write connection; the thread takes *every* job
waiting, runs them in one ``BEGIN IMMEDIATE`` transaction (each job in its own savepoint, so a
job that raises — a conflicting answer, say — leaves no trace and does not disturb the others),
commits once, and only then answers each job.  So "acknowledged ⇒ durable" holds exactly as with
a commit per answer (the acknowledgement waits for the commit that contains it), while one fsync
covers all the answers that arrived during the previous one.  No delay is added to collect a
batch: a lone answer is committed at once.

Several server processes each have their own writer; SQLite's write lock (``BEGIN IMMEDIATE``
with the busy timeout) orders their batches.

Libraries considered: ``aiosqlite`` (a thread per connection, one commit per call: no batching),
SQLAlchemy's asyncio extension (the same, through aiosqlite), ``sqlite3`` in a thread pool (one
commit per call).  None batches commits, so this is written on the standard ``sqlite3`` module.
"""

from __future__ import annotations

import asyncio
import collections
import sqlite3
import threading
import time
from concurrent.futures import Future
from typing import Any, Callable

MAX_BATCH = 512


def connect(path: str, *, synchronous: str = "FULL", timeout_s: float = 30.0,
            read_only: bool = False) -> sqlite3.Connection:
    """A ``sqlite3`` connection in autocommit mode (transactions are explicit) with the pragmas
    the listening database uses: WAL journal, ``synchronous``, busy timeout, foreign keys."""
    conn = sqlite3.connect(path, timeout=timeout_s, isolation_level=None, check_same_thread=False)
    conn.execute("PRAGMA journal_mode=WAL")
    conn.execute(f"PRAGMA synchronous={synchronous}")
    conn.execute(f"PRAGMA busy_timeout={int(timeout_s * 1000)}")
    conn.execute("PRAGMA foreign_keys=ON")
    if read_only:
        conn.execute("PRAGMA query_only=ON")
    return conn


class _Job:
    __slots__ = ("fn", "loop", "future")

    def __init__(self, fn, loop, future):
        self.fn, self.loop, self.future = fn, loop, future


def _deliver(future, result, exc):
    if future.done():  # the awaiting request was cancelled (client gone); the write stands
        return
    if exc is not None:
        future.set_exception(exc)
    else:
        future.set_result(result)


class GroupCommitWriter:
    """Runs write jobs ``fn(conn) -> result`` on one thread, many per transaction.

    Parameters
    ----------
    path : str
        The SQLite database file.
    synchronous : str
        ``"FULL"`` (an acknowledged write survives a power cut) or ``"NORMAL"`` (survives a killed
        process; WAL commits are not fsynced).
    lock : threading.Lock, optional
        Held while a batch runs; other writers in this process (SQLAlchemy) take the same lock, so
        they never meet SQLite's busy handler.
    timeout_s : float
        How long a batch waits for another process's write lock before its jobs fail.
    """

    def __init__(self, path: str, *, synchronous: str = "FULL", lock=None, timeout_s: float = 30.0):
        self.path, self.synchronous, self.timeout_s = path, synchronous, timeout_s
        self._lock = lock or threading.Lock()
        self._jobs: collections.deque[_Job] = collections.deque()
        self._wake = threading.Condition(threading.Lock())
        self._thread: threading.Thread | None = None
        self._closed = False
        self._start_lock = threading.Lock()
        self.batches = 0  # commits so far (for the benchmark's batch-size figure)
        self.jobs_done = 0

    # -- submitting ------------------------------------------------------------------------
    async def run(self, fn: Callable[[sqlite3.Connection], Any]) -> Any:
        """Run ``fn`` in the next batch; returns its result once the batch is committed."""
        loop = asyncio.get_running_loop()
        fut = loop.create_future()
        self._put(_Job(fn, loop, fut))
        return await fut

    def run_sync(self, fn: Callable[[sqlite3.Connection], Any]) -> Any:
        """The same from a thread (blocks until committed)."""
        fut: Future = Future()
        self._put(_Job(fn, None, fut))
        return fut.result()

    def _put(self, job: _Job) -> None:
        if self._thread is None:
            self._start()
        with self._wake:  # checked under the lock the thread drains under: no job is stranded
            if self._closed:
                raise RuntimeError("the database is closed")
            self._jobs.append(job)
            self._wake.notify()

    def _start(self) -> None:
        with self._start_lock:
            if self._thread is None:
                conn = connect(self.path, synchronous=self.synchronous, timeout_s=self.timeout_s)
                t = threading.Thread(target=self._loop, args=(conn,), name="sqlite-group-commit",
                                     daemon=True)
                t.start()
                self._thread = t

    def close(self) -> None:
        """Finish the queued jobs and stop the thread."""
        with self._wake:
            self._closed = True
            self._wake.notify()
        t = self._thread
        if t is not None:
            t.join(30)

    # -- the thread ------------------------------------------------------------------------
    def _loop(self, conn: sqlite3.Connection) -> None:
        try:
            while True:
                with self._wake:
                    while not self._jobs and not self._closed:
                        self._wake.wait()
                    if not self._jobs:  # closed and drained
                        return
                    batch = []
                    while self._jobs and len(batch) < MAX_BATCH:
                        batch.append(self._jobs.popleft())
                self._run_batch(conn, batch)
        finally:
            conn.close()

    def _begin(self, conn: sqlite3.Connection) -> None:
        """``BEGIN IMMEDIATE``, retried every ~0.5 ms while another process holds the write lock,
        up to the busy timeout.  SQLite's own busy handler sleeps 1, 2, 5, 10, 15, 20, 25 ... ms
        between tries, and with several worker processes those sleeps showed in the answer's p95
        (a batch is about a millisecond of work)."""
        conn.execute("PRAGMA busy_timeout=0")
        try:
            deadline = time.monotonic() + self.timeout_s
            while True:
                try:
                    conn.execute("BEGIN IMMEDIATE")
                    return
                except sqlite3.OperationalError as exc:
                    busy = getattr(exc, "sqlite_errorcode", sqlite3.SQLITE_BUSY) == sqlite3.SQLITE_BUSY \
                        and "locked" in str(exc)
                    if not busy or time.monotonic() > deadline:
                        raise
                time.sleep(0.0005)
        finally:
            conn.execute(f"PRAGMA busy_timeout={int(self.timeout_s * 1000)}")

    def _run_batch(self, conn: sqlite3.Connection, batch: list[_Job]) -> None:
        results: list[tuple[Any, BaseException | None]] = []
        try:
            with self._lock:
                self._begin(conn)
                try:
                    for job in batch:
                        conn.execute("SAVEPOINT job")
                        try:
                            r = job.fn(conn)
                        except Exception as exc:  # noqa: BLE001 - handed back to the job's caller
                            conn.execute("ROLLBACK TO job")
                            conn.execute("RELEASE job")
                            results.append((None, exc))
                        else:
                            conn.execute("RELEASE job")
                            results.append((r, None))
                    conn.execute("COMMIT")
                except BaseException:
                    if conn.in_transaction:
                        conn.execute("ROLLBACK")
                    raise
        except Exception as exc:  # noqa: BLE001 - BEGIN/COMMIT failed: nothing of the batch is stored
            results = [(None, exc)] * len(batch)
        self.batches += 1
        self.jobs_done += len(batch)
        for job, (r, exc) in zip(batch, results):
            if job.loop is None:
                _deliver(job.future, r, exc)
            else:
                try:
                    job.loop.call_soon_threadsafe(_deliver, job.future, r, exc)
                except RuntimeError:  # the caller's event loop has closed
                    pass


__all__ = ["GroupCommitWriter", "connect"]
