"""Access to ``headmotion serve``: API keys (hashed in the key file, Bearer header only), per-key
stream and rate limits, the startup rule (no keys: localhost only) and the hash-key helper."""

from __future__ import annotations

import json

import numpy as np
import pytest
from serve_helpers import SPEECH, WS, client, read_until_close, start

from headmotion.errors import FormatError, ParameterError
from headmotion.serve.auth import KeyStore, hash_key, key_line, load_keys
from headmotion.serve.config import ServeConfig, check_bind
from headmotion.serve.runner import preflight

KEYS = [("good-key-1", "alice", 1, 600), ("slow-key-2", "bob", 4, 6)]


@pytest.fixture()
def c(tmp_path):
    with client(tmp_path, keys=KEYS) as cl:
        yield cl


def _post(cl, headers=None):
    return cl.post("/v1/motion?model=stream", content=SPEECH.read_bytes(),
                   headers={"content-type": "audio/wav", **(headers or {})})


@pytest.mark.parametrize("headers,status", [
    ({}, 401), ({"authorization": "Bearer wrong"}, 401), ({"authorization": "good-key-1"}, 401),
    ({"authorization": "Basic good-key-1"}, 401), ({"authorization": "Bearer good-key-1"}, 200),
    ({"authorization": "bearer  good-key-1 "}, 200)])
def test_offline_keys(c, headers, status):
    r = _post(c, headers)
    assert r.status_code == status
    if status == 401:
        assert r.json()["error"] == "unauthorized" and r.headers["www-authenticate"].startswith("Bearer")
    assert c.get("/v1/models", headers=headers).status_code == status


def test_key_never_in_url_or_log(c, caplog):
    import logging

    from headmotion.serve.metrics import log

    log.propagate = True
    try:
        with caplog.at_level(logging.INFO, logger="headmotion.serve"):
            assert _post(c, {"authorization": "Bearer good-key-1"}).status_code == 200
            assert c.post("/v1/motion?model=stream&api_key=good-key-1", content=SPEECH.read_bytes(),
                          headers={"content-type": "audio/wav"}).status_code == 401
    finally:
        log.propagate = False
    lines = [json.loads(r.getMessage()) for r in caplog.records]
    assert any(d.get("key") == "alice" and d["status"] == 200 for d in lines)
    assert "good-key-1" not in caplog.text


@pytest.mark.parametrize("headers,first,kind", [
    ({}, start(), "unauthorized"), ({"authorization": "Bearer nope"}, start(), "unauthorized"),
    ({}, start(api_key="nope"), "unauthorized")])
def test_stream_keys_refused(c, headers, first, kind):
    with c.websocket_connect(WS, headers=headers) as ws:
        ws.send_text(first)
        out = read_until_close(ws)
    assert json.loads(out[0]["text"])["error"] == kind and out[-1]["code"] == 1008


def test_stream_key_in_header_or_start_message(c):
    for headers, first in (({"authorization": "Bearer good-key-1"}, start()), ({}, start(api_key="good-key-1"))):
        with c.websocket_connect(WS, headers=headers) as ws:
            ws.send_text(first)
            assert json.loads(ws.receive_text())["type"] == "ready"


def test_concurrent_streams_per_key(c):
    hdr = {"authorization": "Bearer good-key-1"}
    with c.websocket_connect(WS, headers=hdr) as ws1:
        ws1.send_text(start())
        assert json.loads(ws1.receive_text())["type"] == "ready"
        with c.websocket_connect(WS, headers=hdr) as ws2:  # alice has one stream
            ws2.send_text(start())
            out = read_until_close(ws2)
        assert json.loads(out[0]["text"])["error"] == "too_many_streams" and out[-1]["code"] == 1013
        with c.websocket_connect(WS, headers={"authorization": "Bearer slow-key-2"}) as ws3:  # bob is not limited by alice
            ws3.send_text(start())
            assert json.loads(ws3.receive_text())["type"] == "ready"
        ws1.send_bytes(np.zeros(1600, "<f4").tobytes())
        ws1.send_text('{"type": "end"}')
        assert read_until_close(ws1)[-1]["code"] == 1000


def test_rate_limit_per_key(c):
    bob = {"authorization": "Bearer slow-key-2"}  # 6 per minute: a burst of 1
    assert _post(c, bob).status_code == 200
    r = _post(c, bob)
    assert r.status_code == 429 and r.json()["error"] == "rate_limited" and int(r.headers["retry-after"]) >= 1
    with c.websocket_connect(WS, headers=bob) as ws:
        ws.send_text(start())
        out = read_until_close(ws)
    assert json.loads(out[0]["text"])["error"] == "rate_limited" and out[-1]["code"] == 1013
    assert _post(c, {"authorization": "Bearer good-key-1"}).status_code == 200  # alice unaffected


def test_key_file(tmp_path):
    line = key_line("secret", name="carol", streams=2, rate=30)
    assert line.startswith(hash_key("secret")) and "secret" not in line.split()[0][7:] + line.split(" ", 1)[1]
    p = tmp_path / "k.txt"
    p.write_text(f"# clients\n{line}\n\n")
    keys = load_keys(p)
    assert KeyStore(keys).identify("Bearer secret").name == "carol"
    assert KeyStore(keys).identify("Bearer secret2") is None
    for bad in ("md5:abc", hash_key("x") + " streams=0", hash_key("x") + " colour=red", ""):
        p.write_text(bad + "\n")
        with pytest.raises(FormatError, match="k.txt"):
            load_keys(p)


def test_startup_refused_off_localhost_without_keys(tmp_path):
    for host in ("0.0.0.0", "::", "192.168.1.5", "example.org"):
        with pytest.raises(ParameterError, match="--api-keys"):
            check_bind(host, None)
    for host in ("127.0.0.1", "localhost", "::1"):
        check_bind(host, None)
    keys = tmp_path / "keys.txt"
    keys.write_text(key_line("k", name="a") + "\n")
    assert "stream" in preflight(ServeConfig(host="0.0.0.0", api_keys=str(keys)))
    with pytest.raises(ParameterError):
        preflight(ServeConfig(host="0.0.0.0"))


def test_cli_refuses_and_makes_keys(tmp_path, capsys):
    from headmotion.cli import main

    assert main(["serve", "--host", "0.0.0.0", "--port", "0"]) == 2
    assert "--api-keys" in capsys.readouterr().err
    kf = tmp_path / "keys.txt"
    assert main(["serve", "hash-key", "--name", "dave", "--streams", "3", "--key-file", str(kf)]) == 0
    key = next(ln.split()[1] for ln in capsys.readouterr().out.splitlines() if ln.startswith("key:"))
    k = KeyStore(load_keys(kf)).identify(f"Bearer {key}")
    assert (k.name, k.streams) == ("dave", 3)
    assert key not in kf.read_text()


def test_keys_reloaded_when_the_file_changes(tmp_path):
    """A key removed from the key file is refused on the next request (after the check interval),
    a key added is accepted, without a restart; a broken file keeps the keys in force."""
    import os

    with client(tmp_path, keys=[("old-key", "old", 2, 600)]) as cl:
        store = cl.app.state.serve.keys
        store.check_every = 0.0
        kf = store.path
        assert _post(cl, {"authorization": "Bearer old-key"}).status_code == 200
        kf.write_text(key_line("new-key", name="new") + "\n")
        st = kf.stat()
        os.utime(kf, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # a visible change whatever the clock's grain
        assert _post(cl, {"authorization": "Bearer old-key"}).status_code == 401
        assert _post(cl, {"authorization": "Bearer new-key"}).status_code == 200
        with cl.websocket_connect(WS, headers={"authorization": "Bearer old-key"}) as ws:
            out = read_until_close(ws)
        assert json.loads(out[0]["text"])["error"] == "unauthorized"
        kf.write_text("not a key line\n")
        os.utime(kf, ns=(st.st_atime_ns, st.st_mtime_ns + 2 * 10**9))
        assert _post(cl, {"authorization": "Bearer new-key"}).status_code == 200  # kept
