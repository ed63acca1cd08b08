"""The listening-test server under load and failure, as deployed: ``headmotion listen serve`` in a
subprocess (uvicorn on 127.0.0.1), driven over HTTP with httpx.

* load: 50 simulated participants submit concurrently — no error responses, no answer lost or
  duplicated, every stored value equals the one sent;
* fault: the server is SIGKILLed mid-test and restarted — every answer acknowledged before the
  kill is still there and the participants resume where they were;
* PostgreSQL: the same load through ``--database postgresql://...`` when a throwaway cluster can be
  started (Debian ``postgresql`` + ``psycopg``), else skipped with the reason.
"""

from __future__ import annotations

import asyncio
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
import pytest
from listening_driver import driver

ADMIN = "admin-secret"
pytestmark = pytest.mark.slow


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """``headmotion listen serve CONFIG`` in a subprocess."""

    def __init__(self, config: Path, database: str, port: int | None = None):
        self.config, self.database = config, database
        self.port = port or _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.start()

    def start(self):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "headmotion", "listen", "serve", str(self.config), "--port",
             str(self.port), "--database", self.database, "--admin-token", ADMIN],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.time() + 60
        while time.time() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server died: {self.proc.stderr.read().decode()[-2000:]}")
            try:
                if httpx.get(self.url + "/api/test", timeout=2).status_code == 200:
                    return
            except httpx.HTTPError:
                time.sleep(0.1)
        raise RuntimeError("server did not start")

    def kill(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(10)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(10)

    def answers(self) -> list[dict]:
        r = httpx.get(self.url + "/api/admin/results.json",
                      headers={"Authorization": f"Bearer {ADMIN}"}, timeout=30)
        r.raise_for_status()
        return r.json()["answers"]


@pytest.fixture
def test_dir(tmp_path, examples_dir) -> Path:
    d = tmp_path / "t"
    shutil.copytree(examples_dir / "listening", d, ignore=shutil.ignore_patterns("results"))
    return d


async def _participant(client, pnum, sent, errors, *, demographics, token=None, stop_after=None,
                       registered=None):
    """Run one participant to the end; record acked answers in ``sent``.  A dropped connection
    (the server killed) ends the participant quietly; ``registered[pnum]`` keeps its token."""
    registered = {} if registered is None else registered
    try:
        return await _participant_steps(client, pnum, sent, errors, demographics=demographics,
                                        token=token, stop_after=stop_after, registered=registered)
    except httpx.TransportError:
        return registered.get(pnum)


async def _finish_intro(client, token, stage):
    if stage == "demographics":
        return await client.post(f"/api/p/{token}/demographics", json={"answers": {
            "native_language": "yes", "listening": "speakers", "gender": "other"}})
    return await client.post(f"/api/p/{token}/start")


async def _participant_steps(client, pnum, sent, errors, *, demographics, token, stop_after,
                             registered):
    if token is None:
        r = await client.post("/api/participants", json={"consent": True})
        if r.status_code != 201:
            errors.append((pnum, "register", r.status_code, r.text))
            return None
        token = r.json()["token"]
        registered[pnum] = token
        if demographics:
            r = await _finish_intro(client, token, "demographics")
            if r.status_code != 200:
                errors.append((pnum, "demographics", r.status_code, r.text))
        r = await client.post(f"/api/p/{token}/start")
        if r.status_code != 200:
            errors.append((pnum, "start", r.status_code, r.text))
    n = 0
    while stop_after is None or n < stop_after:
        r = await client.get(f"/api/p/{token}/state")
        if r.status_code != 200:
            errors.append((pnum, "state", r.status_code, r.text))
            return token
        st = r.json()
        if st["stage"] == "done":
            return token
        if st["stage"] in ("demographics", "instructions"):
            # a participant resuming (the server was killed between registration and the first
            # trial) carries on from the stage the server reports, as the browser page does
            r = await _finish_intro(client, token, st["stage"])
            if r.status_code != 200:
                errors.append((pnum, st["stage"], r.status_code, r.text))
                return token
            continue
        trial = st["trial"]
        body = {"trial_index": trial["index"], **driver.answer_for(trial, pnum)}
        r = await client.post(f"/api/p/{token}/answer", json=body)
        if r.status_code != 200:
            errors.append((pnum, "answer", r.status_code, r.text))
            return token
        sent[(token, trial["index"])] = body
        if trial["index"] % 5 == 0:  # a browser retry after a lost response: must not duplicate
            r2 = await client.post(f"/api/p/{token}/answer", json=body)
            if r2.status_code != 200 or not r2.json()["duplicate"]:
                errors.append((pnum, "retry", r2.status_code, r2.text))
        n += 1
    return token


def _check_stored(answers: list[dict], sent: dict, tokens: dict) -> None:
    pid_of = tokens  # token -> participant id
    keys = [(a["participant"], a["trial_index"], a["slot"]) for a in answers]
    assert len(keys) == len(set(keys)), "an answer was stored twice"
    stored = {(a["participant"], a["trial_index"], a["slot"]): a for a in answers}
    for (token, idx), body in sent.items():
        pid = pid_of[token]
        if "rating" in body:
            assert stored[(pid, idx, "A")]["value"] == body["rating"]
        elif "ratings" in body:
            for lab, v in body["ratings"].items():
                assert stored[(pid, idx, lab)]["value"] == v
        else:
            match = [a for k, a in stored.items() if k[:2] == (pid, idx)]
            assert len(match) == 1
            assert body["choice"] in (match[0]["slot"], match[0]["condition"])


async def _run_panel(url: str, n: int, *, demographics: bool, sent: dict, errors: list,
                     stop_after=None, tokens=None, registered=None):
    limits = httpx.Limits(max_connections=n, max_keepalive_connections=n)
    async with httpx.AsyncClient(base_url=url, timeout=60, limits=limits) as client:
        coros = [_participant(client, p, sent, errors, demographics=demographics,
                              token=None if tokens is None else tokens[p], stop_after=stop_after,
                              registered=registered)
                 for p in range(n)]
        return await asyncio.gather(*coros, return_exceptions=True)


def _load_test(server: Server, n_trials: int, demographics: bool, n: int = 50):
    sent: dict = {}
    errors: list = []
    t0 = time.time()
    toks = asyncio.run(_run_panel(server.url, n, demographics=demographics, sent=sent,
                                  errors=errors))
    elapsed = time.time() - t0
    assert not [t for t in toks if isinstance(t, BaseException)], toks
    assert errors == []
    answers = server.answers()
    first = next(iter(sent.values()))
    per_trial = len(first["ratings"]) if "ratings" in first else 1
    assert len(sent) == n * n_trials
    by_pid: dict[int, list[dict]] = {}
    for a in answers:
        by_pid.setdefault(a["participant"], []).append(a)
    assert len(by_pid) == n and all(len(v) == n_trials * per_trial for v in by_pid.values())
    print(f"{n} participants x {n_trials} trials in {elapsed:.1f} s")
    return sent, answers


def _pid_by_token(db_url: str) -> dict:
    import sqlalchemy as sa

    from headmotion.listening.db import participants

    eng = sa.create_engine(db_url)
    with eng.connect() as c:
        out = {r.token: r.id for r in c.execute(sa.select(participants.c.token, participants.c.id))}
    eng.dispose()
    return out


def test_load_50_concurrent_participants_sqlite(test_dir, tmp_path):
    db = f"sqlite:///{tmp_path / 'load.sqlite'}"
    srv = Server(test_dir / "mushra.yaml", db)
    try:
        sent, answers = _load_test(srv, 4, demographics=True)
        _check_stored(answers, sent, _pid_by_token(db))
    finally:
        srv.stop()


def test_sigkill_mid_test_keeps_acknowledged_answers_and_participants_resume(test_dir, tmp_path):
    db = f"sqlite:///{tmp_path / 'fault.sqlite'}"
    srv = Server(test_dir / "mushra.yaml", db)
    sent: dict = {}
    errors: list = []
    registered: dict = {}
    n = 12

    async def run_and_kill():
        task = asyncio.create_task(_run_panel(srv.url, n, demographics=True, sent=sent,
                                              errors=errors, registered=registered))
        while len(sent) < 20:  # kill while answers are in flight
            await asyncio.sleep(0.01)
            if task.done():
                break
        srv.kill()
        return await task

    try:
        asyncio.run(run_and_kill())
        assert errors == []
        assert 20 <= len(sent) < n * 4, "the kill should land mid-test"
        srv.start()  # same database, same port
        answers = srv.answers()
        pid_by_token = _pid_by_token(db)
        _check_stored(answers, sent, pid_by_token)  # every acknowledged answer survived
        # resume: every registered participant carries on from its next unanswered trial
        tokens = list(registered.values())
        assert len(tokens) >= 5, registered
        for t in tokens:
            st = httpx.get(f"{srv.url}/api/p/{t}/state").json()
            acked = sum(1 for (tok, _i) in sent if tok == t)
            assert st["progress"]["done"] >= acked  # an unacknowledged commit may also be there
        sent2: dict = {}
        errors2: list = []
        toks = asyncio.run(_run_panel(srv.url, len(tokens), demographics=False, sent=sent2,
                                      errors=errors2, tokens=tokens))
        assert not [t for t in toks if isinstance(t, BaseException)], toks
        assert errors2 == []
        answers = srv.answers()
        _check_stored(answers, {**sent, **sent2}, pid_by_token)
        for t in tokens:
            st = httpx.get(f"{srv.url}/api/p/{t}/state").json()
            assert st["stage"] == "done" and st["progress"]["done"] == 4
        keys = [(a["participant"], a["trial_index"], a["slot"]) for a in answers]
        assert len(keys) == len(set(keys))
    finally:
        srv.stop()


# ---------------------------------------------------------------------------------------------
# PostgreSQL (throwaway cluster)
# ---------------------------------------------------------------------------------------------
def _pg_bin() -> Path | None:
    for base in sorted(Path("/usr/lib/postgresql").glob("*/bin"), reverse=True):
        if (base / "initdb").exists() and (base / "pg_ctl").exists():
            return base
    return None


@pytest.fixture
def postgres_url():
    pytest.importorskip("psycopg", reason="psycopg not installed (pip install 'psycopg[binary]')")
    bindir = _pg_bin()
    if bindir is None:
        pytest.skip("PostgreSQL server binaries not installed (apt-get install postgresql)")
    as_user: list[str] = []
    if os.geteuid() == 0:
        if shutil.which("runuser") is None:
            pytest.skip("running as root without runuser: cannot start PostgreSQL")
        try:
            import pwd

            pw = pwd.getpwnam("postgres")
        except KeyError:
            pytest.skip("no 'postgres' user to run a throwaway cluster as")
        as_user = ["runuser", "-u", "postgres", "--"]
    d = Path(tempfile.mkdtemp(prefix="hm-pg-"))
    if as_user:
        os.chown(d, pw.pw_uid, pw.pw_gid)
    data = d / "data"
    port = _free_port()
    r = subprocess.run(as_user + [str(bindir / "initdb"), "-D", str(data), "-U", "postgres",
                                  "--auth=trust", "-E", "UTF8"], capture_output=True, text=True)
    if r.returncode != 0:
        shutil.rmtree(d, ignore_errors=True)
        pytest.skip(f"initdb failed: {r.stderr[-500:]}")
    r = subprocess.run(as_user + [str(bindir / "pg_ctl"), "-D", str(data), "-l", str(d / "log"),
                                  "-w", "-t", "60", "-o",
                                  f"-p {port} -k {d} -c listen_addresses=127.0.0.1 "
                                  "-c max_connections=100 -c fsync=on", "start"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        shutil.rmtree(d, ignore_errors=True)
        pytest.skip(f"pg_ctl start failed: {r.stderr[-500:]}")
    try:
        yield f"postgresql://postgres@127.0.0.1:{port}/postgres"
    finally:
        subprocess.run(as_user + [str(bindir / "pg_ctl"), "-D", str(data), "-m", "immediate",
                                  "stop"], capture_output=True)
        shutil.rmtree(d, ignore_errors=True)


def test_load_concurrent_participants_postgres(test_dir, postgres_url):
    srv = Server(test_dir / "mushra.yaml", postgres_url)
    try:
        sent, answers = _load_test(srv, 4, demographics=True, n=20)
        _check_stored(answers, sent, _pid_by_token(postgres_url.replace(
            "postgresql://", "postgresql+psycopg://")))
        # and the SIGKILL fault path: acked answers survive a killed server
        srv.kill()
        srv.start()
        assert len(srv.answers()) == len(answers)
    finally:
        srv.stop()


def test_participants_killed_before_their_first_trial_resume_from_their_stage(test_dir, tmp_path):
    """A kill between registration and the first trial leaves participants at ``demographics`` or
    ``instructions``; on the restarted server they carry on from there to the end."""
    srv = Server(test_dir / "mushra.yaml", f"sqlite:///{tmp_path / 'intro.sqlite'}")
    try:
        at_demographics = httpx.post(f"{srv.url}/api/participants", json={"consent": True}).json()
        at_instructions = httpx.post(f"{srv.url}/api/participants", json={"consent": True}).json()
        tokens = [at_demographics["token"], at_instructions["token"]]
        async def demographics_only():
            async with httpx.AsyncClient(base_url=srv.url) as client:
                return await _finish_intro(client, tokens[1], "demographics")

        assert asyncio.run(demographics_only()).status_code == 200
        srv.kill()
        srv.start()
        assert [httpx.get(f"{srv.url}/api/p/{t}/state").json()["stage"] for t in tokens] == [
            "demographics", "instructions"]
        sent: dict = {}
        errors: list = []
        toks = asyncio.run(_run_panel(srv.url, 2, demographics=False, sent=sent, errors=errors,
                                      tokens=tokens))
        assert errors == [] and toks == tokens
        assert len(sent) == 2 * 4
        for t in tokens:
            st = httpx.get(f"{srv.url}/api/p/{t}/state").json()
            assert st["stage"] == "done" and st["progress"]["done"] == 4
    finally:
        srv.stop()
