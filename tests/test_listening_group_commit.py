"""The SQLite group-commit writer of the listening server (``listening/sqlite_writer.py``).

Known answers: jobs queued while a batch is held up are committed together (two commits for 50
answers); a job that raises leaves nothing behind and does not disturb its batch; a batch whose
COMMIT fails acknowledges none of its jobs and stores nothing; an acknowledged write is visible to
another connection at once; another connection's write lock is waited for up to the timeout;
closing finishes the queued jobs; ``durable`` selects ``synchronous`` FULL (2) or NORMAL (1)."""

from __future__ import annotations

import asyncio
import sqlite3
import threading
import time

import pytest

from headmotion.listening.db import Conflict, Database
from headmotion.listening.sqlite_writer import GroupCommitWriter, connect


@pytest.fixture
def db_path(tmp_path):
    p = str(tmp_path / "w.sqlite")
    c = connect(p)
    c.execute("CREATE TABLE parent (id INTEGER PRIMARY KEY)")
    c.execute("CREATE TABLE t (k INTEGER PRIMARY KEY, v TEXT NOT NULL)")
    c.execute("CREATE TABLE child (id INTEGER PRIMARY KEY, parent INTEGER REFERENCES parent(id) "
              "DEFERRABLE INITIALLY DEFERRED)")
    c.close()
    return p


def _insert(k, v="x"):
    def job(conn):
        conn.execute("INSERT INTO t (k, v) VALUES (?, ?)", (k, v))
        return k

    return job


def _rows(path, table="t"):
    c = sqlite3.connect(path)
    try:
        return c.execute(f"SELECT * FROM {table} ORDER BY 1").fetchall()
    finally:
        c.close()


def test_jobs_waiting_during_a_commit_share_the_next_one(db_path):
    lock = threading.Lock()
    w = GroupCommitWriter(db_path, lock=lock)

    async def main():
        with lock:  # hold the first batch up, as a slow fsync would
            first = asyncio.ensure_future(w.run(_insert(0)))
            await asyncio.sleep(0.05)
            rest = [asyncio.ensure_future(w.run(_insert(k))) for k in range(1, 50)]
            await asyncio.sleep(0.05)
            assert not first.done() and not any(f.done() for f in rest)  # nothing acknowledged
        return await first, await asyncio.gather(*rest)

    first, rest = asyncio.run(main())
    assert [first, *rest] == list(range(50))
    assert w.batches == 2 and w.jobs_done == 50
    assert _rows(db_path) == [(k, "x") for k in range(50)]
    w.close()


def test_a_failing_job_leaves_no_trace_and_spares_its_batch(db_path):
    lock = threading.Lock()
    w = GroupCommitWriter(db_path, lock=lock)

    def half_then_fail(conn):
        conn.execute("INSERT INTO t (k, v) VALUES (100, 'half')")
        raise Conflict("rejected after writing")

    async def main():
        with lock:
            futs = [asyncio.ensure_future(w.run(j)) for j in (_insert(1), half_then_fail, _insert(2))]
            await asyncio.sleep(0.05)
        return await asyncio.gather(*futs, return_exceptions=True)

    a, b, c = asyncio.run(main())
    assert (a, c) == (1, 2) and isinstance(b, Conflict)
    assert _rows(db_path) == [(1, "x"), (2, "x")]  # row 100 rolled back with its job
    w.close()


def test_a_failed_commit_acknowledges_nothing(db_path):
    lock = threading.Lock()
    w = GroupCommitWriter(db_path, lock=lock)

    def orphan(conn):  # a deferred foreign key: the statement succeeds, the COMMIT fails
        conn.execute("INSERT INTO child (id, parent) VALUES (1, 999)")

    async def main():
        with lock:
            futs = [asyncio.ensure_future(w.run(j)) for j in (_insert(1), orphan, _insert(2))]
            await asyncio.sleep(0.05)
        return await asyncio.gather(*futs, return_exceptions=True)

    results = asyncio.run(main())
    assert all(isinstance(r, sqlite3.IntegrityError) for r in results), results
    assert _rows(db_path) == [] and _rows(db_path, "child") == []
    assert w.run_sync(_insert(3)) == 3  # the writer carries on
    assert _rows(db_path) == [(3, "x")]
    w.close()


def test_acknowledged_means_committed_for_other_connections_and_threads(db_path):
    w = GroupCommitWriter(db_path)
    other = sqlite3.connect(db_path)
    errors = []

    def worker(base):
        try:
            for k in range(base, base + 20):
                w.run_sync(_insert(k))
                got = other_local().execute("SELECT v FROM t WHERE k = ?", (k,)).fetchall()
                assert got == [("x",)], k
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    local = threading.local()

    def other_local():
        if not hasattr(local, "c"):
            local.c = sqlite3.connect(db_path)
        return local.c

    threads = [threading.Thread(target=worker, args=(100 * i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert other.execute("SELECT count(*) FROM t").fetchone()[0] == 80
    w.close()


@pytest.mark.parametrize("durable, level", [(True, 2), (False, 1)])
def test_durable_selects_synchronous_full_or_normal(tmp_path, durable, level):
    db = Database(f"sqlite:///{tmp_path / 'd.sqlite'}", durable=durable)
    assert db._writer.run_sync(lambda c: c.execute("PRAGMA synchronous").fetchone()[0]) == level
    assert db._writer.run_sync(lambda c: c.execute("PRAGMA journal_mode").fetchone()[0]) == "wal"
    db.close()


def test_in_memory_sqlite_is_refused(tmp_path):
    from headmotion.errors import ParameterError

    with pytest.raises(ParameterError, match="must be a file"):
        Database("sqlite:///:memory:")


def test_another_process_holding_the_write_lock_is_waited_for_up_to_the_timeout(db_path):
    """Another connection (as another worker process would) holds SQLite's write lock: the batch
    waits for it and commits after it is released; held past ``timeout_s``, the jobs fail."""
    holder = connect(db_path)
    holder.execute("BEGIN IMMEDIATE")
    release = threading.Timer(0.3, lambda: holder.execute("COMMIT"))
    w = GroupCommitWriter(db_path, timeout_s=5.0)
    t0 = time.perf_counter()
    release.start()
    assert w.run_sync(_insert(1)) == 1
    waited = time.perf_counter() - t0
    assert waited >= 0.25, waited  # it waited for the lock (and did not fail)
    w.close()

    holder.execute("BEGIN IMMEDIATE")
    short = GroupCommitWriter(db_path, timeout_s=0.2)
    with pytest.raises(sqlite3.OperationalError, match="locked"):
        short.run_sync(_insert(2))
    holder.execute("COMMIT")
    assert short.run_sync(_insert(3)) == 3
    assert _rows(db_path) == [(1, "x"), (3, "x")]
    short.close()
    holder.close()


def test_closing_finishes_the_queued_jobs_and_refuses_new_ones(db_path):
    lock = threading.Lock()
    w = GroupCommitWriter(db_path, lock=lock)
    results = []
    with lock:
        threads = [threading.Thread(target=lambda k=k: results.append(w.run_sync(_insert(k))))
                   for k in range(5)]
        for t in threads:
            t.start()
        closer = threading.Thread(target=w.close)
        time.sleep(0.1)
        closer.start()
        time.sleep(0.05)
    closer.join()
    for t in threads:
        t.join()
    assert sorted(results) == list(range(5))
    with pytest.raises(RuntimeError, match="closed"):
        w.run_sync(_insert(9))
