"""The listening-test server hardened.

In-process (TestClient): a rebinding ``Host`` gets 400; security headers on every response; the
admin token is traded for an HttpOnly SameSite=Strict cookie and never accepted in an API URL;
admin POSTs need the CSRF header; cross-site POSTs are refused; bodies are size-limited;
registration is rate-limited per address and capped.

As deployed (``headmotion listen serve --workers 4`` in its own process group, driven over HTTP
by ``benchmarks/listening_load.py``): 300 concurrent participants finish with every acknowledged
answer stored exactly once, and SIGKILL of the whole server mid-load loses nothing acknowledged.
"""

from __future__ import annotations

import asyncio
import shutil
import warnings
from pathlib import Path

import pytest

from listening_driver import driver

from headmotion.listening.app import CSP, create_app, split_host
from headmotion.listening.config import load_config

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

ROOT = Path(__file__).resolve().parents[1]


L = driver


@pytest.fixture
def test_dir(tmp_path):
    d = tmp_path / "t"
    shutil.copytree(ROOT / "examples" / "listening", d, ignore=shutil.ignore_patterns("results"))
    return d


def _client(test_dir, tmp_path, *, extra_yaml: str = "", name="config.yaml", **kw):
    p = test_dir / name
    if extra_yaml:
        p.write_text(p.read_text() + "\n" + extra_yaml + "\n")
    cfg = load_config(p)
    app = create_app(cfg, database_url=f"sqlite:///{tmp_path / 'db.sqlite'}", admin_token="tok",
                     allowed_hosts=["testserver", "study.example.org"], **kw)
    return TestClient(app), app


# -------------------------------------------------------------------------------------- hosts
@pytest.mark.parametrize("host,ok", [("attacker.example", False), ("attacker.example:8000", False),
                                     ("127.0.0.1.attacker.example", False), ("", False),
                                     ("localhost:8000", True), ("127.0.0.1", True), ("[::1]:8000", True),
                                     ("study.example.org", True), ("STUDY.example.org.", True)])
def test_host_allow_list(test_dir, tmp_path, host, ok):
    c, _ = _client(test_dir, tmp_path)
    for path in ("/", "/admin", "/api/test"):
        r = c.get(path, headers={"Host": host})
        assert (r.status_code == 200) == ok, (path, host, r.status_code)
        if not ok:
            assert r.status_code == 400 and "host not allowed" in r.text
    r = c.get("/api/admin/progress", headers={"Host": host, "X-Admin-Token": "tok"})
    assert r.status_code == (200 if ok else 400)


def test_split_host():
    assert split_host("[::1]:8000") == "::1" and split_host("Example.ORG:80") == "example.org"
    assert split_host("localhost.") == "localhost"


def test_served_host_and_allowed_host_option(test_dir, tmp_path):
    cfg = load_config(test_dir / "config.yaml")
    app = create_app(cfg, database_url=f"sqlite:///{tmp_path / 'db.sqlite'}", admin_token="t",
                     served_host="10.1.2.3", allowed_hosts=["lab.example"])
    assert {"localhost", "127.0.0.1", "::1", "10.1.2.3", "lab.example"} <= app.state.allowed_hosts
    c = TestClient(app, base_url="http://10.1.2.3:8000")
    assert c.get("/").status_code == 200
    assert c.get("/", headers={"Host": "evil.example"}).status_code == 400


# ------------------------------------------------------------------------------------ headers
def test_security_headers_on_every_response(test_dir, tmp_path):
    c, _ = _client(test_dir, tmp_path)
    responses = [c.get("/"), c.get("/admin"), c.get("/static/app.js"), c.get("/api/test"),
                 c.get("/api/p/nope/state"), c.get("/no/such/page"), c.get("/", headers={"Host": "x.example"}),
                 c.post("/api/participants", json={"consent": True})]
    for r in responses:
        h = r.headers
        assert h["content-security-policy"] == CSP, r.url
        assert "frame-ancestors 'none'" in h["content-security-policy"]
        assert h["x-content-type-options"] == "nosniff"
        assert h["referrer-policy"] == "no-referrer"
        assert h["x-frame-options"] == "DENY"
    assert c.get("/api/test").headers["cache-control"] == "no-store"


# ---------------------------------------------------------------------------------- admin
def test_admin_token_leaves_the_url_for_an_httponly_cookie(test_dir, tmp_path):
    c, _ = _client(test_dir, tmp_path)
    r = c.get("/admin?token=tok", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/admin"
    cookie = r.headers["set-cookie"]
    assert cookie.startswith("hm_admin=") and "HttpOnly" in cookie and "SameSite=strict" in cookie
    assert "tok" not in cookie.split(";")[0].split("=", 1)[1]  # a keyed hash, not the token
    assert c.get("/api/admin/progress").status_code == 200  # the cookie is enough
    c2, _ = _client(test_dir, tmp_path / "2") if (tmp_path / "2").mkdir() is None else None
    r = c2.get("/admin?token=wrong", follow_redirects=False)
    assert r.status_code == 303 and "hm_admin" not in r.headers.get("set-cookie", "")
    assert c2.get("/api/admin/progress").status_code == 401
    assert c2.get("/api/admin/progress?token=tok").status_code == 401  # never from the URL
    assert c2.get("/api/admin/results.csv", headers={"Authorization": "Bearer tok"}).status_code == 200


def test_admin_posts_need_the_csrf_header(test_dir, tmp_path):
    c, _ = _client(test_dir, tmp_path)
    page = c.get("/admin")
    csrf = page.cookies.get("hm_csrf") or c.cookies.get("hm_csrf")
    assert csrf
    assert c.post("/api/admin/session", json={"token": "tok"}).status_code == 403
    assert c.post("/api/admin/session", json={"token": "tok"}, headers={"X-CSRF-Token": "forged"}).status_code == 403
    assert c.get("/api/admin/progress").status_code == 401
    r = c.post("/api/admin/session", json={"token": "tok"}, headers={"X-CSRF-Token": csrf,
                                                                    "Origin": "http://evil.example"})
    assert r.status_code == 403  # cross-site, even with the right header
    r = c.post("/api/admin/session", json={"token": "wrong"}, headers={"X-CSRF-Token": csrf})
    assert r.status_code == 401
    r = c.post("/api/admin/session", json={"token": "tok"}, headers={"X-CSRF-Token": csrf,
                                                                    "Origin": "http://testserver"})
    assert r.status_code == 200 and "HttpOnly" in r.headers["set-cookie"]
    assert c.get("/api/admin/progress").status_code == 200
    assert c.post("/api/admin/logout").status_code == 403
    assert c.post("/api/admin/logout", headers={"X-CSRF-Token": csrf}).status_code == 200
    assert c.get("/api/admin/progress").status_code == 401


def test_cross_site_participant_post_is_refused(test_dir, tmp_path):
    c, _ = _client(test_dir, tmp_path)
    r = c.post("/api/participants", json={"consent": True}, headers={"Origin": "http://evil.example"})
    assert r.status_code == 403
    r = c.post("/api/participants", json={"consent": True}, headers={"Origin": "null"})
    assert r.status_code == 403
    r = c.post("/api/participants", json={"consent": True}, headers={"Origin": "http://testserver"})
    assert r.status_code == 201


def test_the_per_trial_requests_are_behind_the_same_guard(test_dir, tmp_path):
    """The state read and the answer POST are served outside FastAPI (trials_api): the Host
    allow-list, Origin check, body limit and headers still apply, errors keep FastAPI's shape, and
    nothing refused is stored."""
    c, app = _client(test_dir, tmp_path)
    tok = c.post("/api/participants", json={"consent": True}).json()["token"]
    assert c.post(f"/api/p/{tok}/demographics", json={"answers": {
        "native_language": "yes", "listening": "speakers", "gender": "male", "age": None}}).status_code == 200
    assert c.post(f"/api/p/{tok}/start").status_code == 200
    st = c.get(f"/api/p/{tok}/state")
    assert st.status_code == 200 and st.headers["cache-control"] == "no-store"
    assert st.headers["content-security-policy"] == CSP and st.headers["x-frame-options"] == "DENY"
    good = {"trial_index": 0, "rating": 3}
    answer = f"/api/p/{tok}/answer"
    assert c.get(f"/api/p/{tok}/state", headers={"Host": "attacker.example"}).status_code == 400
    assert c.post(answer, json=good, headers={"Host": "attacker.example"}).status_code == 400
    assert c.post(answer, json=good, headers={"Origin": "http://evil.example"}).status_code == 403
    r = c.post(answer, json={**good, "pad": "x" * 100_000})
    assert r.status_code == 413 and r.headers["x-content-type-options"] == "nosniff"
    r = c.post(answer, content=(b"x" * 1024 for _ in range(100)), headers={"Content-Type": "application/json"})
    assert r.status_code == 413
    r = c.post(answer, content=b"{not json", headers={"Content-Type": "application/json"})
    assert r.status_code == 422 and isinstance(r.json()["detail"], list)
    r = c.post(answer, json={**good, "participant": 2})  # extra fields are refused
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "extra_forbidden"
    r = c.get(answer)
    assert r.status_code == 405 and r.headers["allow"] == "POST"
    assert c.post(f"/api/p/{tok}/state").status_code == 405
    assert app.state.db.count_answers() == 0
    r = c.post(answer, json=good)
    assert r.status_code == 200 and r.json() == {"stored": 1, "duplicate": False, "next_trial": 1, "done": False}
    assert r.headers["referrer-policy"] == "no-referrer" and r.headers["cache-control"] == "no-store"
    assert c.get(f"/api/p/{tok}/state").json()["progress"]["done"] == 1


# ----------------------------------------------------------------------------------- limits
def test_request_body_size_limit(test_dir, tmp_path):
    c, _ = _client(test_dir, tmp_path)
    tok = c.post("/api/participants", json={"consent": True}).json()["token"]
    big = {"answers": {"native_language": "x" * 100_000}}
    r = c.post(f"/api/p/{tok}/demographics", json=big)
    assert r.status_code == 413

    def chunks():  # no Content-Length: the limit holds while the body streams in
        for _ in range(100):
            yield b"x" * 1024

    r = c.post(f"/api/p/{tok}/demographics", content=chunks(), headers={"Content-Type": "application/json"})
    assert r.status_code == 413


def test_registration_rate_limit_per_address(test_dir, tmp_path):
    c, app = _client(test_dir, tmp_path, extra_yaml="registrations_per_address: 3\nregistration_window_s: 60")
    codes = [c.post("/api/participants", json={"consent": True}).status_code for _ in range(5)]
    assert codes == [201, 201, 201, 429, 429]
    assert len(app.state.db.progress()) == 3  # refused registrations leave nothing behind
    local = TestClient(app, client=("127.0.0.1", 50000))  # the lab machine itself is not limited
    assert [local.post("/api/participants", json={"consent": True}).status_code for _ in range(4)] == [201] * 4


def test_participant_cap(test_dir, tmp_path):
    c, app = _client(test_dir, tmp_path, extra_yaml="max_participants: 4")
    codes = [c.post("/api/participants", json={"consent": True}).status_code for _ in range(6)]
    assert codes == [201] * 4 + [403] * 2
    assert "full" in c.post("/api/participants", json={"consent": True}).text
    assert len(app.state.db.progress()) == 4


def test_config_rejects_bad_limits(test_dir):
    from headmotion.errors import FormatError

    p = test_dir / "config.yaml"
    p.write_text(p.read_text() + "\nmax_participants: 0\n")
    with pytest.raises(FormatError, match="max_participants"):
        load_config(p)


# -------------------------------------------------------------------------- as deployed
@pytest.mark.slow
def test_300_participants_over_4_workers_every_answer_stored_once(tmp_path):
    cfg = L.make_test_dir(tmp_path / "t", n_items=4)
    db = f"sqlite:///{tmp_path / 'load.sqlite'}"
    srv = L.ServerProc(cfg, db, workers=4)
    try:
        res = L.load(srv.url, 300, think_s=0.05)
        assert res["errors"] == []
        assert res["answers"] == 300 * 4
        answers = srv.answers()
        L.check_stored(answers, res["sent"], L.pid_by_token(db))
        assert len(answers) == 300 * 4 * 4  # 4 MUSHRA slots per trial, nothing extra
    finally:
        srv.stop()
    print(f"300 participants / 4 workers: {res['answers_per_s']:.0f} answers/s, p95 {res['p95_ms']:.0f} ms")


@pytest.mark.slow
def test_sigkill_of_the_whole_server_mid_load_loses_nothing_acknowledged(tmp_path):
    cfg = L.make_test_dir(tmp_path / "t", n_items=6)
    db = f"sqlite:///{tmp_path / 'kill.sqlite'}"
    srv = L.ServerProc(cfg, db, workers=4)
    sent: dict = {}
    lat: list = []
    errors: list = []
    registered: dict = {}

    async def run_and_kill():
        task = asyncio.create_task(L.run_panel(srv.url, 60, sent=sent, latencies=lat, errors=errors,
                                               registered=registered))
        while len(sent) < 100 and not task.done():
            await asyncio.sleep(0.01)
        srv.kill()  # master and workers, mid-load
        await task

    try:
        asyncio.run(run_and_kill())
        assert errors == []
        assert 100 <= len(sent) < 60 * 6, "the kill should land mid-load"
        srv.start()
        answers = srv.answers()
        L.check_stored(answers, sent, L.pid_by_token(db))  # every acknowledged answer is there, once
    finally:
        srv.stop()


@pytest.mark.slow
def test_4_workers_on_postgresql(tmp_path, request):
    """The same load through ``--database postgresql://...`` with 4 workers (a throwaway cluster,
    as in test_listening_server.py; skipped when PostgreSQL is not installed)."""
    import sys

    sys.path.insert(0, str(ROOT / "tests"))
    import test_listening_server as tls

    gen = tls.postgres_url.__wrapped__() if hasattr(tls.postgres_url, "__wrapped__") else None
    url = next(gen)
    try:
        cfg = L.make_test_dir(tmp_path / "t", n_items=4)
        srv = L.ServerProc(cfg, url, workers=4)
        try:
            res = L.load(srv.url, 100, think_s=0.05)
            assert res["errors"] == []
            answers = srv.answers()
            L.check_stored(answers, res["sent"], L.pid_by_token(url.replace("postgresql://", "postgresql+psycopg://")))
            assert len(answers) == 100 * 4 * 4
        finally:
            srv.stop()
    finally:
        gen.close()
