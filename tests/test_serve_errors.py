"""``headmotion serve``'s answers to what it refuses: one error shape ``{"error", "detail"}`` for
every HTTP error (the router's 404/405 too), a ``not_found`` error on another WebSocket path,
``too_large`` for a message past the WebSocket layer's limit (counted as such), the controls'
stated ranges (the same for Python, the command line, HTTP and the stream) and unknown query
parameters refused by name, CORS for allowed origins, the key checked before a large message,
connections not yet started counted toward the stream limit, key-free routes that spend no rate,
and a port in use refused before any banner."""

from __future__ import annotations

import asyncio
import json
import socket

import numpy as np
import pytest
from serve_helpers import SPEECH, WS, client, read_until_close, registry, start

from headmotion.errors import ParameterError
from headmotion.synthesis import GAIN_RANGE, OFFSET_RANGE_DEG, SEED_MAX, Controls, check_seed


@pytest.fixture(scope="module")
def c():
    with client() as cl:
        yield cl


def _post(cl, query, headers=None):
    return cl.post(f"/v1/motion?{query}", content=SPEECH.read_bytes(),
                   headers={"content-type": "audio/wav", **(headers or {})})


@pytest.mark.parametrize("method,path,status,kind", [
    ("get", "/nope", 404, "not_found"), ("get", "/v1/motion", 405, "method_not_allowed"),
    ("delete", "/v1/models", 405, "method_not_allowed")])
def test_router_errors_have_the_api_shape(c, method, path, status, kind):
    r = getattr(c, method)(path)
    assert r.status_code == status
    assert set(r.json()) == {"error", "detail"} and r.json()["error"] == kind and path in r.json()["detail"]


def test_host_and_origin_refusals_have_the_api_shape(c):
    r = c.get("/healthz", headers={"host": "evil.example"})
    assert r.status_code == 400 and r.json()["error"] == "bad_host"
    r = _post(c, "model=stream", {"origin": "https://evil.example"})
    assert r.status_code == 403 and r.json()["error"] == "bad_origin"


def test_another_websocket_path_gets_not_found(c):
    with c.websocket_connect("ws://localhost/v1/streams") as ws:
        out = read_until_close(ws)
    err = json.loads(out[0]["text"])
    assert err["type"] == "error" and err["error"] == "not_found" and "/v1/stream" in err["detail"]
    assert out[-1]["code"] == 1008 and out[-1]["reason"].startswith("not_found")


@pytest.mark.parametrize("query,needle", [
    ("gain=1e6", "between 0 and 10"), ("gain=1e308", "between 0 and 10"), ("gain=-1", "between 0 and 10"),
    ("gain_pitch=10.5", "between 0 and 10"), ("gain=1,1,-0.1", "between 0 and 10"),
    ("offset=1e9", "between -90 and 90 degrees"), ("offset_roll=-91", "between -90 and 90 degrees"),
    ("seed=99999999999999999999", "4294967295"), ("seed=-1", "0 to 4294967295"),
    (f"seed={SEED_MAX}&samples=2", "seed + samples - 1"), ("fps=5000", "between 1 and 1000"),
    ("gain_ptich=2", "'gain_ptich'"), ("model=stream&api_key=x", "'api_key'"),
    ("amount=3.5", "from 0 to 3"), ("amount=-1", "from 0 to 3")])
def test_offline_controls_out_of_range_or_unknown(c, query, needle):
    r = _post(c, f"model=stream&{query}" if not query.startswith("model") else query)
    assert r.status_code == 400, r.text
    assert r.json()["error"] == "bad_parameter" and needle in r.json()["detail"], r.json()


@pytest.mark.parametrize("query", ["amount=3.5", "gain=11", "offset_pitch=-91", "seed=-1", "fps=0"])
def test_offline_errors_name_the_query_parameters_not_the_command_line_options(c, query):
    r = _post(c, f"model=stream&{query}")
    assert r.status_code == 400, r.text
    detail = r.json()["detail"]
    assert "--" not in detail, detail
    assert detail.startswith(query.split("=")[0].split("_")[0]), detail


def test_service_words_for_library_messages():
    from headmotion.serve.access import api_wording

    assert api_wording("amount (--amount) must be a number from 0 to 3; got 5") == \
        "amount must be a number from 0 to 3; got 5"
    assert api_wording("a tws-basic model does not do that; use --gain or --gain-pitch") == \
        "a tws-basic model does not do that; use gain or gain_pitch"


def test_offline_controls_at_the_edges_of_their_ranges(c):
    r = _post(c, f"model=stream&gain=0,10,1&offset=-90,0,90&seed={SEED_MAX}&format=json")
    assert r.status_code == 200, r.text
    assert len(r.json()["frames"]) > 50


@pytest.mark.parametrize("fields,needle", [
    ({"gain": -1}, "between 0 and 10"), ({"gain": [1, 1, 11]}, "between 0 and 10"),
    ({"offset": [0, 100, 0]}, "between -90 and 90 degrees"), ({"seed": 2 ** 32}, "0 to 4294967295"),
    ({"resample": "best"}, "resample"), ({"amount": 4}, "from 0 to 3"), ({"amount": "lots"}, "amount must be a number")])
def test_stream_start_out_of_range(c, fields, needle):
    with c.websocket_connect(WS) as ws:
        ws.send_text(start(**fields))
        out = read_until_close(ws)
    err = json.loads(out[0]["text"])
    assert err["error"] == "bad_start" and needle in err["detail"] and out[-1]["code"] == 1008


def test_python_and_command_line_share_the_ranges(tmp_path, capsys):
    assert GAIN_RANGE == (0.0, 10.0) and OFFSET_RANGE_DEG == (-90.0, 90.0) and SEED_MAX == 2 ** 32 - 1
    for bad in ({"gain": -0.5}, {"gain": "1,20,1"}, {"offset_degrees": 95}, {"offset": 2.0}):
        with pytest.raises(ParameterError, match="between"):
            Controls.parse(**bad)
    with pytest.raises(ParameterError, match="4294967295"):
        check_seed(2 ** 32)
    check_seed(SEED_MAX)
    from headmotion.cli import main

    out = tmp_path / "m.json"
    assert main(["synth", str(SPEECH), "-o", str(out), "--gain", "-1"]) == 2
    assert "between 0 and 10" in capsys.readouterr().err and not out.exists()


def test_cors_for_an_allowed_origin():
    with client(origins=("https://app.example.com/",)) as cl:
        pre = cl.options("/v1/motion", headers={"origin": "https://app.example.com",
                                                "access-control-request-method": "POST",
                                                "access-control-request-headers": "authorization,content-type"})
        assert pre.status_code == 200
        assert pre.headers["access-control-allow-origin"] == "https://app.example.com"
        assert "POST" in pre.headers["access-control-allow-methods"]
        assert "authorization" in pre.headers["access-control-allow-headers"].lower()
        r = _post(cl, "model=stream", {"origin": "https://app.example.com"})
        assert r.status_code == 200 and r.headers["access-control-allow-origin"] == "https://app.example.com"
        assert "x-headmotion-model" in r.headers["access-control-expose-headers"].lower()
        other = cl.options("/v1/motion", headers={"origin": "https://evil.example",
                                                  "access-control-request-method": "POST"})
        assert "access-control-allow-origin" not in other.headers
    with client() as plain:  # no allowed origin: no CORS answer
        pre = plain.options("/v1/motion", headers={"origin": "https://app.example.com",
                                                   "access-control-request-method": "POST"})
        assert "access-control-allow-origin" not in pre.headers and pre.json()["error"] == "method_not_allowed"


def test_key_free_routes_spend_no_rate(tmp_path):
    with client(tmp_path, keys=[("k", "bob", 4, 6)]) as cl:  # 6 per minute: a burst of one request
        hdr = {"authorization": "Bearer k"}
        for _ in range(5):
            assert cl.get("/v1/models", headers=hdr).status_code == 200
            assert cl.get("/metrics", headers=hdr).status_code == 200
        assert cl.get("/metrics").status_code == 401
        assert _post(cl, "model=stream", hdr).status_code == 200  # the one request of the burst
        r = _post(cl, "model=stream", hdr)
        assert r.status_code == 429 and int(r.headers["retry-after"]) >= 1
        with cl.websocket_connect(WS, headers=hdr) as ws:  # the stream's refusal says when to retry too
            ws.send_text(start())
            out = read_until_close(ws)
        err = json.loads(out[0]["text"])
        assert err["error"] == "rate_limited" and err["retry_after"] >= 1 and out[-1]["code"] == 1013


def test_connections_not_yet_started_count_toward_the_stream_limit():
    with client(max_streams=1) as cl:
        with cl.websocket_connect(WS) as idle:  # connected, nothing sent yet
            with cl.websocket_connect(WS) as ws:
                ws.send_text(start())
                out = read_until_close(ws)
            err = json.loads(out[0]["text"])
            assert err["error"] == "busy" and out[-1]["code"] == 1013
            idle.send_text(start())
            assert json.loads(idle.receive_text())["type"] == "ready"
        assert cl.app.state.serve.slots.load() == 0


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """A real server (the command's WebSocket protocol) with keys and a 100 kB message limit (the
    WebSocket layer's limit 400 kB, four times it, as the command sets it)."""
    from headmotion.serve.app import create_app
    from headmotion.serve.auth import key_line
    from headmotion.serve.config import Limits, ServeConfig
    from headmotion.serve.protocol import WS_PROTOCOL
    from headmotion.web.server import running_app

    kf = tmp_path_factory.mktemp("keys") / "keys.txt"
    kf.write_text(key_line("real-key", name="r") + "\n")
    app = create_app(ServeConfig(api_keys=str(kf), limits=Limits(max_message_bytes=100_000)), registry=registry())
    with running_app(app, ws=WS_PROTOCOL, ws_max_size=400_000) as url:
        yield url.rstrip("/").replace("http", "ws") + "/v1/stream", app.state.serve


async def _exchange(url, msgs, headers=None):
    import websockets

    got = []
    async with websockets.connect(url, additional_headers=headers or {}, max_size=None) as ws:
        try:
            for m in msgs:
                await ws.send(m)
            async for m in ws:
                got.append(m)
        except websockets.ConnectionClosed:
            pass
        return got, ws.close_code, ws.close_reason


def test_message_over_the_websocket_limit_is_too_large_and_counted(real):
    url, st = real
    before = st.metrics.errors.labels("too_large")._value.get()
    got, code, reason = asyncio.run(_exchange(url, [start(), b"\x00" * 500_000], {"authorization": "Bearer real-key"}))
    errs = [json.loads(m) for m in got if isinstance(m, str) and '"error"' in m]
    assert [e["error"] for e in errs] == ["too_large"] and code == 1009 and reason.startswith("too_large")
    for _ in range(100):
        if st.metrics.errors.labels("too_large")._value.get() > before:
            break
        asyncio.run(asyncio.sleep(0.02))
    assert st.metrics.errors.labels("too_large")._value.get() == before + 1


def test_key_checked_before_a_large_first_message(real):
    from headmotion.serve.stream import UNAUTHENTICATED_MESSAGE_BYTES

    url, st = real
    # a wrong header: refused before anything is read
    got, code, _ = asyncio.run(_exchange(url, [], {"authorization": "Bearer wrong"}))
    assert json.loads(got[0])["error"] == "unauthorized" and code == 1008
    # no header: the first message is capped (the key in it not yet known), far below the usual limit
    big = json.dumps({"type": "start", "api_key": "real-key", "pad": "x" * (UNAUTHENTICATED_MESSAGE_BYTES + 10)})
    assert len(big) < 400_000 / 4
    got, code, reason = asyncio.run(_exchange(url, [big]))
    assert code == 1009 and reason.startswith("too_large")
    # the same message after a key in the header: read, and refused for what it says
    got, code, reason = asyncio.run(_exchange(url, [big], {"authorization": "Bearer real-key"}))
    assert json.loads(got[0])["error"] == "bad_start" and "pad" in json.loads(got[0])["detail"] and code == 1008
    # a start message with the key: a stream
    got, code, _ = asyncio.run(_exchange(url, [start(api_key="real-key", encoding="f32le"),
                                               np.zeros(200, "<f4").tobytes(), '{"type": "end"}']))
    assert json.loads(got[0])["type"] == "ready" and json.loads(got[-1])["type"] == "end" and code == 1000
    assert st.slots.load() == 0


def test_port_in_use_refused_before_any_banner(capsys):
    from headmotion.cli import main

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        assert main(["serve", "--port", str(port)]) == 2
    out = capsys.readouterr()
    assert "cannot listen on 127.0.0.1:" in out.err and "--port" in out.err
    assert out.out == "" and len(out.err.strip().splitlines()) == 1  # one error line, no banner
