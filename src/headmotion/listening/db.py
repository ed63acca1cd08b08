"""Storage of participants and answers for a listening test (SQLAlchemy Core).

SQLite is the embedded default — one file per test, WAL journal (readers never block the writer),
``synchronous=FULL`` so that every answer acknowledged to a browser survives a killed server and a
power cut — and ``postgresql://...`` URLs are accepted for larger deployments (needs the
``psycopg`` driver).

The two requests every trial makes (the state read and the answer) take a short path on SQLite:
the state is one indexed ``SELECT`` on a plain ``sqlite3`` connection of the calling thread, and
answers go through :class:`~headmotion.listening.sqlite_writer.GroupCommitWriter` — one thread
that commits all the answers waiting in one transaction and acknowledges each only after that
commit (one fsync for many answers; "acknowledged ⇒ durable" unchanged).  Through SQLAlchemy Core
the same two requests cost ~0.45 ms of CPU more per answer (state read 0.16 vs 0.013 ms, answer
write 0.35 vs 0.045 ms).  Everything else (registration, stage
changes, admin reads, PostgreSQL) goes through SQLAlchemy.  The rules an answer must satisfy are
one function (:func:`check_answer`) used by both paths.

Integrity is enforced by the database, not only by the app: an answer row is unique per
(participant, trial, slot) and a participant's ``next_trial`` pointer moves forward in the same
transaction that stores the answer, so a resubmitted or concurrent duplicate can never be stored
twice and a stored rating can never be changed ("participants were not allowed to re-evaluate
videos once they made their decision", thesis §4.2.3.1).

Several server processes (``headmotion listen serve --workers N``) may share one database: SQLite
through WAL and a 30 s busy timeout (each request is one short transaction), PostgreSQL through row
locks (``SELECT ... FOR UPDATE``) and an advisory lock around registration.  A unique-constraint
race between processes (a browser retry landing on another worker) is retried once and then
reads as the duplicate it is.  Registrations are counted in their own table so that a per-address
rate limit and a participant cap hold across processes (:meth:`Database.create_participant`).

Libraries considered: the SQLAlchemy ORM (not needed for four tables), ``databases``/``encode``
(async only, unmaintained), raw ``sqlite3`` (no PostgreSQL path).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import secrets
import threading
import time
from pathlib import Path
from typing import Any, Callable

import sqlalchemy as sa

from ..errors import HeadMotionError, MissingDependencyError, ParameterError
from .sqlite_writer import GroupCommitWriter, connect

metadata = sa.MetaData()

meta_table = sa.Table(
    "meta", metadata,
    sa.Column("key", sa.String(64), primary_key=True),
    sa.Column("value", sa.Text, nullable=False),
)

participants = sa.Table(
    "participants", metadata,
    sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("token", sa.String(64), nullable=False, unique=True),
    sa.Column("created_at", sa.Float, nullable=False),
    sa.Column("stage", sa.String(16), nullable=False),  # demographics | instructions | trials | done
    sa.Column("demographics", sa.Text, nullable=False, default="{}"),
    sa.Column("next_trial", sa.Integer, nullable=False, default=0),
    sa.Column("n_trials", sa.Integer, nullable=False),
    sa.Column("plan", sa.Text, nullable=False),
    sa.Column("user_agent", sa.Text, nullable=False, default=""),
    sa.Column("finished_at", sa.Float, nullable=True),
)

answers = sa.Table(
    "answers", metadata,
    sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("participant_id", sa.Integer, sa.ForeignKey("participants.id"), nullable=False),
    sa.Column("trial_index", sa.Integer, nullable=False),
    sa.Column("phase", sa.String(16), nullable=False),     # training | test | attention
    sa.Column("kind", sa.String(16), nullable=False),      # mos | mushra | ab | attention
    sa.Column("item", sa.Text, nullable=False),
    sa.Column("speaker", sa.Text, nullable=False, default=""),
    sa.Column("grp", sa.Text, nullable=False, default=""),
    sa.Column("slot", sa.String(16), nullable=False),      # A, B, ... / left, right / choice
    sa.Column("condition", sa.Text, nullable=False),       # system name (or the chosen option)
    sa.Column("value", sa.Float, nullable=True),           # rating / 1 if chosen (A/B)
    sa.Column("other", sa.Text, nullable=False, default=""),  # A/B: the system not chosen
    sa.Column("response_ms", sa.Float, nullable=True),
    sa.Column("created_at", sa.Float, nullable=False),
    sa.UniqueConstraint("participant_id", "trial_index", "slot", name="uq_answer_slot"),
)

registrations = sa.Table(
    "registrations", metadata,
    sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("addr", sa.String(64), nullable=False, index=True),  # keyed hash of the address
    sa.Column("created_at", sa.Float, nullable=False),
)

ANSWER_COLUMNS = ("participant", "trial_index", "phase", "kind", "item", "speaker", "group",
                  "slot", "condition", "value", "other", "response_ms", "created_at")


class NotFound(HeadMotionError, LookupError):
    """No participant with that token."""


class Conflict(HeadMotionError, RuntimeError):
    """The request contradicts what is stored (answer changed, trial not reached, ...)."""


class Full(HeadMotionError, RuntimeError):
    """The test has as many participants as its configuration allows."""


class RateLimited(HeadMotionError, RuntimeError):
    """Too many registrations from one client address in the window."""


def _sqlite_pragmas(synchronous: str):
    def on_connect(dbapi_conn, _record):
        cur = dbapi_conn.cursor()
        cur.execute("PRAGMA journal_mode=WAL")
        cur.execute(f"PRAGMA synchronous={synchronous}")
        cur.execute("PRAGMA busy_timeout=30000")
        cur.execute("PRAGMA foreign_keys=ON")
        cur.close()

    return on_connect


class Database:
    """Participants and answers of one test.

    Parameters
    ----------
    url : str
        ``sqlite:///path/to/file.sqlite`` (the folder is created) or ``postgresql://...``.
    durable : bool
        SQLite only: ``synchronous=FULL`` (default; an acknowledged answer survives even a power
        cut) or ``NORMAL`` (survives a killed process, not a power cut; WAL commits are not
        fsynced).  With group commit, FULL costs one fsync per batch of answers, not per answer.
    """

    def __init__(self, url: str, *, durable: bool = True):
        self.url = url
        u = sa.engine.make_url(url)
        self.is_sqlite = u.get_backend_name() == "sqlite"
        self._writer: GroupCommitWriter | None = None
        if self.is_sqlite:
            if not u.database or u.database == ":memory:" or u.database.startswith("file:"):
                raise ParameterError(f"a listening test's SQLite database must be a file "
                                     f"(sqlite:///path/to/test.sqlite); got {url!r}")
            Path(u.database).parent.mkdir(parents=True, exist_ok=True)
            self.sqlite_path = str(Path(u.database).resolve())
            self.synchronous = "FULL" if durable else "NORMAL"
            self.engine = sa.create_engine(u, connect_args={"check_same_thread": False,
                                                            "timeout": 30})
            sa.event.listen(self.engine, "connect",
                            _sqlite_pragmas("FULL" if durable else "NORMAL"))
        elif u.get_backend_name() == "postgresql":
            if u.drivername == "postgresql":
                u = u.set(drivername="postgresql+psycopg")
            try:
                # at most 15 connections per server process, so that --workers 4 stays well
                # inside PostgreSQL's default max_connections (100)
                self.engine = sa.create_engine(u, pool_size=5, max_overflow=10, pool_timeout=60,
                                               pool_pre_ping=True)
            except ModuleNotFoundError as exc:
                raise MissingDependencyError(
                    f"the PostgreSQL database {url!r} needs the psycopg driver "
                    f"(pip install 'psycopg[binary]'): {exc}") from None
        else:
            raise ParameterError(f"database URL must be sqlite:///FILE or postgresql://...; "
                                 f"got {url!r}")
        # SQLite allows one writer; serialising writers in-process avoids busy retries.
        self._lock = threading.Lock() if self.is_sqlite else contextlib.nullcontext()
        self._readers = threading.local()  # SQLite: one plain read connection per thread
        self._plans: dict[str, tuple[int, list[dict]]] = {}
        for attempt in range(3):  # workers starting together may race on CREATE TABLE
            try:
                metadata.create_all(self.engine)
                break
            except (sa.exc.OperationalError, sa.exc.ProgrammingError, sa.exc.IntegrityError):
                if attempt == 2:
                    raise
                time.sleep(0.2)
        if self.is_sqlite:
            self._writer = GroupCommitWriter(self.sqlite_path, synchronous=self.synchronous,
                                             lock=self._lock)

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
        conn = getattr(self._readers, "conn", None)
        if conn is not None:  # this thread's reader (other threads' close when they end)
            conn.close()
            self._readers.conn = None
        self.engine.dispose()

    def _reader(self):
        """This thread's plain ``sqlite3`` connection for the per-trial state read."""
        conn = getattr(self._readers, "conn", None)
        if conn is None:
            conn = self._readers.conn = connect(self.sqlite_path, synchronous=self.synchronous,
                                                read_only=True)
        return conn

    # -- meta ------------------------------------------------------------------------------
    def set_meta(self, key: str, value: Any) -> None:
        text = json.dumps(value)
        for attempt in range(3):  # several workers start at once: upsert, retried on a race
            try:
                with self._lock, self.engine.begin() as c:
                    n = c.execute(sa.update(meta_table).where(meta_table.c.key == key)
                                  .values(value=text)).rowcount
                    if not n:
                        c.execute(sa.insert(meta_table).values(key=key, value=text))
                return
            except sa.exc.IntegrityError:
                if attempt == 2:
                    raise

    def get_or_set_meta(self, key: str, make: Callable[[], Any]) -> Any:
        """The stored value of ``key``; if there is none, store ``make()`` — once, even when
        several processes ask at the same moment (the first insert wins, the others read it)."""
        got = self.get_meta(key)
        if got is not None:
            return got
        try:
            with self._lock, self.engine.begin() as c:
                c.execute(sa.insert(meta_table).values(key=key, value=json.dumps(make())))
        except sa.exc.IntegrityError:
            pass
        return self.get_meta(key)

    def get_meta(self, key: str, default: Any = None) -> Any:
        with self.engine.connect() as c:
            row = c.execute(sa.select(meta_table.c.value).where(meta_table.c.key == key)).first()
        return default if row is None else json.loads(row[0])

    # -- participants ----------------------------------------------------------------------
    def create_participant(self, plan_for: Callable[[int], list[dict]], *, user_agent: str = "",
                           stage: str = "demographics", addr: str = "", max_participants: int | None = None,
                           per_address: int | None = None, window_s: float = 3600.0) -> dict[str, Any]:
        """Register a participant; ``plan_for(number)`` makes the trial plan from its number.

        Raises :class:`Full` when ``max_participants`` are registered already and
        :class:`RateLimited` when ``addr`` registered ``per_address`` participants in the last
        ``window_s`` seconds.  The rows are written first and counted after, in one transaction
        (SQLite: the write holds the database's write lock; PostgreSQL: an advisory lock), so the
        limits hold across worker processes."""
        kw = dict(user_agent=user_agent, stage=stage, addr=addr, max_participants=max_participants,
                  per_address=per_address, window_s=window_s)
        if self._writer is not None:
            got = self._writer.run_sync(_sqlite_register_job(plan_for, **kw))
        else:
            got = self._create_participant(plan_for, **kw)
        return self._registered(got)

    async def create_participant_async(self, plan_for: Callable[[int], list[dict]],
                                       **kw) -> dict[str, Any]:
        """:meth:`create_participant` for a request handler on the event loop."""
        if self._writer is not None:
            return self._registered(await self._writer.run(_sqlite_register_job(plan_for, **kw)))
        return await asyncio.to_thread(self.create_participant, plan_for, **kw)

    def _registered(self, got: tuple[int, str, str, list[dict]]) -> dict[str, Any]:
        pid, token, stage, plan = got
        self._plans[token] = (pid, plan)
        return {"id": pid, "token": token, "stage": stage}

    def _create_participant(self, plan_for, *, user_agent, stage, addr, max_participants,
                            per_address, window_s) -> tuple[int, str, str, list[dict]]:
        """PostgreSQL: one transaction under an advisory lock."""
        token = secrets.token_urlsafe(24)
        now = time.time()
        with self._lock, self.engine.begin() as c:
            c.execute(sa.text("SELECT pg_advisory_xact_lock(1836346224)"))
            c.execute(sa.insert(registrations).values(addr=addr[:64], created_at=now))
            res = c.execute(sa.insert(participants).values(
                token=token, created_at=now, stage=stage, demographics="{}",
                next_trial=0, n_trials=0, plan="[]", user_agent=user_agent[:500]))
            pid = int(res.inserted_primary_key[0])
            n_all = n_addr = None
            if max_participants is not None:
                n_all = c.execute(sa.select(sa.func.count()).select_from(participants)).scalar_one()
            if per_address is not None and addr:
                n_addr = c.execute(sa.select(sa.func.count()).select_from(registrations).where(
                    registrations.c.addr == addr[:64], registrations.c.created_at > now - window_s)).scalar_one()
            check_limits(n_all, n_addr, max_participants, per_address, window_s)
            plan = plan_for(pid)
            c.execute(sa.update(participants).where(participants.c.id == pid).values(
                plan=json.dumps(plan), n_trials=len(plan)))
        return pid, token, stage, plan

    def plan(self, token: str) -> tuple[int, list[dict]]:
        """``(participant id, trial plan)``; the plan never changes once made, so it is kept in
        memory after the first read."""
        got = self._plans.get(token)
        if got is None:
            p = self.participant(token)
            got = self._plans[token] = (p["id"], p["plan"])
        return got

    async def plan_async(self, token: str) -> tuple[int, list[dict]]:
        """:meth:`plan` for a request handler on the event loop (a cache miss on PostgreSQL
        reads in a thread)."""
        if self.is_sqlite or token in self._plans:
            return self.plan(token)
        return await asyncio.to_thread(self.plan, token)

    def participant(self, token: str) -> dict[str, Any]:
        if not isinstance(token, str) or not token or len(token) > 64:
            raise NotFound(token)
        with self.engine.connect() as c:
            row = c.execute(sa.select(participants).where(participants.c.token == token)).first()
        if row is None:
            raise NotFound(token)
        d = dict(row._mapping)
        d["plan"] = json.loads(d["plan"])
        d["demographics"] = json.loads(d["demographics"])
        return d

    def progress_of(self, token: str) -> dict[str, Any]:
        """``{"id", "stage", "next_trial", "n_trials", "plan"}`` — the per-request state, with the
        (immutable) plan from the in-memory cache: one small indexed SELECT."""
        if not isinstance(token, str) or not token or len(token) > 64:
            raise NotFound(token)
        if self.is_sqlite:
            # fetchall: the statement is finished, so no read transaction stays open
            found = self._reader().execute(
                "SELECT id, stage, next_trial, n_trials FROM participants WHERE token = ?",
                (token,)).fetchall()
            row = found[0] if found else None
        else:
            with self.engine.connect() as c:
                row = c.execute(sa.select(participants.c.id, participants.c.stage,
                                          participants.c.next_trial, participants.c.n_trials)
                                .where(participants.c.token == token)).first()
        if row is None:
            raise NotFound(token)
        return {"id": row[0], "stage": row[1], "next_trial": row[2], "n_trials": row[3],
                "plan": self.plan(token)[1]}

    async def progress_of_async(self, token: str) -> dict[str, Any]:
        """:meth:`progress_of` for a request handler on the event loop: SQLite's read is a few
        microseconds and runs in place; PostgreSQL's runs in a thread."""
        if self.is_sqlite:
            return self.progress_of(token)
        return await asyncio.to_thread(self.progress_of, token)

    def set_stage(self, token: str, *, expect: str, stage: str,
                  demographics: dict | None = None) -> None:
        """Move a participant from stage ``expect`` to ``stage`` (:class:`Conflict` if it is
        elsewhere), storing its questionnaire answers if given."""
        if self._writer is not None:
            return self._writer.run_sync(_sqlite_stage_job(token, expect, stage, demographics))
        with self._lock, self.engine.begin() as c:
            row = c.execute(sa.select(participants.c.stage).where(
                participants.c.token == token).with_for_update()).first()
            if row is None:
                raise NotFound(token)
            check_stage(row.stage, expect)
            values: dict[str, Any] = {"stage": stage}
            if demographics is not None:
                values["demographics"] = json.dumps(demographics)
            c.execute(sa.update(participants).where(participants.c.token == token).values(**values))
        return None

    async def set_stage_async(self, token: str, *, expect: str, stage: str,
                              demographics: dict | None = None) -> None:
        """:meth:`set_stage` for a request handler on the event loop."""
        if self._writer is not None:
            return await self._writer.run(_sqlite_stage_job(token, expect, stage, demographics))
        return await asyncio.to_thread(self.set_stage, token, expect=expect, stage=stage,
                                       demographics=demographics)

    # -- answers ---------------------------------------------------------------------------
    def submit(self, token: str, trial_index: int, rows: list[dict[str, Any]]) -> dict[str, Any]:
        """Store the answer rows of one trial, exactly once (see :func:`check_answer`).

        Returns ``{"stored": n, "duplicate": bool, "next_trial": k, "done": bool}`` once the
        answer is committed."""
        if self._writer is not None:
            return self._writer.run_sync(_sqlite_submit_job(token, trial_index, rows))
        try:
            return self._submit(token, trial_index, rows)
        except sa.exc.IntegrityError:  # the same answer committed by another process meanwhile
            return self._submit(token, trial_index, rows)

    async def submit_async(self, token: str, trial_index: int,
                           rows: list[dict[str, Any]]) -> dict[str, Any]:
        """:meth:`submit` for a request handler on the event loop: SQLite through the group
        commit writer, PostgreSQL in a thread."""
        if self._writer is not None:
            return await self._writer.run(_sqlite_submit_job(token, trial_index, rows))
        return await asyncio.to_thread(self.submit, token, trial_index, rows)

    def _submit(self, token: str, trial_index: int, rows: list[dict[str, Any]]) -> dict[str, Any]:
        """PostgreSQL: one transaction, the participant's row locked."""
        now = time.time()
        with self._lock, self.engine.begin() as c:
            p = c.execute(sa.select(participants.c.id, participants.c.next_trial,
                                    participants.c.n_trials, participants.c.stage)
                          .where(participants.c.token == token).with_for_update()).first()
            if p is None:
                raise NotFound(token)
            stored = None
            if trial_index < p.next_trial:
                stored = c.execute(sa.select(answers.c.slot, answers.c.condition, answers.c.value)
                                   .where(answers.c.participant_id == p.id,
                                          answers.c.trial_index == trial_index)).all()
            dup = check_answer(p.stage, p.next_trial, p.n_trials, trial_index, rows, stored)
            if dup is not None:
                return dup
            c.execute(sa.insert(answers), [
                {"participant_id": p.id, "trial_index": trial_index, "created_at": now,
                 "speaker": "", "grp": "", "other": "", **r} for r in rows])
            nxt = p.next_trial + 1
            done = nxt >= p.n_trials
            c.execute(sa.update(participants).where(participants.c.id == p.id).values(
                next_trial=nxt, stage="done" if done else "trials",
                finished_at=now if done else None))
        return {"stored": len(rows), "duplicate": False, "next_trial": nxt, "done": done}

    # -- admin -----------------------------------------------------------------------------
    def progress(self) -> list[dict[str, Any]]:
        with self.engine.connect() as c:
            rows = c.execute(sa.select(
                participants.c.id, participants.c.created_at, participants.c.stage,
                participants.c.next_trial, participants.c.n_trials, participants.c.finished_at,
                participants.c.demographics).order_by(participants.c.id)).all()
        return [{**dict(r._mapping), "demographics": json.loads(r.demographics)} for r in rows]

    def answer_rows(self) -> list[dict[str, Any]]:
        """All answers (long format), with the participant's number and demographics."""
        with self.engine.connect() as c:
            rows = c.execute(sa.select(answers, participants.c.demographics)
                             .join(participants, participants.c.id == answers.c.participant_id)
                             .order_by(answers.c.participant_id, answers.c.trial_index,
                                       answers.c.id)).all()
        out = []
        for r in rows:
            m = dict(r._mapping)
            d = {"participant": m["participant_id"], "group": m.pop("grp")}
            d.update({k: m[k] for k in ANSWER_COLUMNS if k in m and k not in d})
            for k, v in json.loads(m["demographics"]).items():
                d[f"demo_{k}"] = v
            out.append(d)
        return out

    def count_answers(self) -> int:
        with self.engine.connect() as c:
            return int(c.execute(sa.select(sa.func.count()).select_from(answers)).scalar_one())


def check_stage(current: str, expect: str) -> None:
    if current != expect:
        raise Conflict(f"participant is at stage {current!r}, not {expect!r}")


def check_limits(n_all: int | None, n_addr: int | None, max_participants: int | None,
                 per_address: int | None, window_s: float) -> None:
    """After the new participant's rows are written: :class:`Full` when there are more than
    ``max_participants``, :class:`RateLimited` when its address registered more than
    ``per_address`` in the window (``None`` counts are not checked)."""
    if max_participants is not None and n_all is not None and n_all > max_participants:
        raise Full(f"the test is full ({max_participants} participants)")
    if per_address is not None and n_addr is not None and n_addr > per_address:
        raise RateLimited(f"more than {per_address} registrations from one address in {window_s:g} s")


def check_answer(stage: str, next_trial: int, n_trials: int, trial_index: int,
                 rows: list[dict[str, Any]], stored) -> dict[str, Any] | None:
    """The rules for storing an answer, given the participant's stored state.

    ``stored`` holds the ``(slot, condition, value)`` rows already stored for ``trial_index``
    (read only when ``trial_index < next_trial``).  Returns ``None`` when the answer is to be
    stored; the acknowledgement of a duplicate when the identical answer was stored already (a
    browser retry after a lost response); raises :class:`Conflict` for a different answer to a
    past trial ("a rating cannot be changed"), an answer to a trial not yet reached, or before the
    trials have started."""
    if stage not in ("trials", "done"):
        raise Conflict(f"participant is at stage {stage!r}; trials have not started")
    if trial_index < next_trial:
        mine = {(r["slot"], r["condition"], r["value"]) for r in rows}
        if {(s[0], s[1], s[2]) for s in stored} == mine:
            return {"stored": 0, "duplicate": True, "next_trial": next_trial,
                    "done": next_trial >= n_trials}
        raise Conflict(f"trial {trial_index} was already answered; a rating cannot be changed")
    if trial_index > next_trial:
        raise Conflict(f"trial {trial_index} has not been reached; the next trial is {next_trial}")
    return None


_INSERT_ANSWER = ("INSERT INTO answers (participant_id, trial_index, phase, kind, item, speaker, grp, "
                  "slot, condition, value, other, response_ms, created_at) "
                  "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)")


def _sqlite_submit_job(token: str, trial_index: int, rows: list[dict[str, Any]]):
    """The answer as a job for the SQLite writer (runs inside its transaction)."""

    def job(conn) -> dict[str, Any]:
        p = conn.execute("SELECT id, next_trial, n_trials, stage FROM participants WHERE token = ?",
                         (token,)).fetchone()
        if p is None:
            raise NotFound(token)
        pid, next_trial, n_trials, stage = p
        stored = None
        if trial_index < next_trial:
            stored = conn.execute("SELECT slot, condition, value FROM answers "
                                  "WHERE participant_id = ? AND trial_index = ?",
                                  (pid, trial_index)).fetchall()
        dup = check_answer(stage, next_trial, n_trials, trial_index, rows, stored)
        if dup is not None:
            return dup
        now = time.time()
        conn.executemany(_INSERT_ANSWER, [
            (pid, trial_index, r["phase"], r["kind"], r["item"], r.get("speaker", ""),
             r.get("grp", ""), r["slot"], r["condition"], r.get("value"), r.get("other", ""),
             r.get("response_ms"), now) for r in rows])
        nxt = next_trial + 1
        done = nxt >= n_trials
        conn.execute("UPDATE participants SET next_trial = ?, stage = ?, finished_at = ? WHERE id = ?",
                     (nxt, "done" if done else "trials", now if done else None, pid))
        return {"stored": len(rows), "duplicate": False, "next_trial": nxt, "done": done}

    return job


def _sqlite_register_job(plan_for, *, user_agent="", stage="demographics", addr="",
                        max_participants=None, per_address=None, window_s=3600.0):
    """Registration as a job for the SQLite writer (its transaction holds the write lock, so the
    counts include every other process's registrations)."""

    def job(conn) -> tuple[int, str, str, list[dict]]:
        token = secrets.token_urlsafe(24)
        now = time.time()
        conn.execute("INSERT INTO registrations (addr, created_at) VALUES (?, ?)", (addr[:64], now))
        cur = conn.execute(
            "INSERT INTO participants (token, created_at, stage, demographics, next_trial, n_trials, "
            "plan, user_agent) VALUES (?, ?, ?, '{}', 0, 0, '[]', ?)", (token, now, stage, user_agent[:500]))
        pid = int(cur.lastrowid)
        n_all = n_addr = None
        if max_participants is not None:
            n_all = conn.execute("SELECT count(*) FROM participants").fetchone()[0]
        if per_address is not None and addr:
            n_addr = conn.execute("SELECT count(*) FROM registrations WHERE addr = ? AND created_at > ?",
                                  (addr[:64], now - window_s)).fetchone()[0]
        check_limits(n_all, n_addr, max_participants, per_address, window_s)
        plan = plan_for(pid)
        conn.execute("UPDATE participants SET plan = ?, n_trials = ? WHERE id = ?",
                     (json.dumps(plan), len(plan), pid))
        return pid, token, stage, plan

    return job


def _sqlite_stage_job(token: str, expect: str, stage: str, demographics: dict | None):
    def job(conn) -> None:
        row = conn.execute("SELECT stage FROM participants WHERE token = ?", (token,)).fetchone()
        if row is None:
            raise NotFound(token)
        check_stage(row[0], expect)
        if demographics is None:
            conn.execute("UPDATE participants SET stage = ? WHERE token = ?", (stage, token))
        else:
            conn.execute("UPDATE participants SET stage = ?, demographics = ? WHERE token = ?",
                         (stage, json.dumps(demographics), token))

    return job


__all__ = ["Database", "NotFound", "Conflict", "Full", "RateLimited", "ANSWER_COLUMNS", "check_answer"]
