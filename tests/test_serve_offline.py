"""``POST /v1/motion``: known answers (the library's predict for the same seed and controls),
formats, controls, errors and limits; the operations routes."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest
from serve_helpers import SPEECH, client, registry, speech_f32

from headmotion.io import load_audio
from headmotion.synthesis import synthesize


@pytest.fixture(scope="module")
def c():
    with client() as cl:
        yield cl


def _npz(data: bytes):
    with np.load(io.BytesIO(data)) as z:
        return {k: z[k] for k in z.files}


def test_offline_equals_library_predict(c):
    model = registry().models["stream"]
    want = synthesize(load_audio(SPEECH), model, seed=3, gain=(1.2, 0.5, 1.2), offset=(np.radians(4.0), 0.0, 0.0))[0]
    r = c.post("/v1/motion?model=stream&seed=3&format=npz&gain=1.2&gain_yaw=0.5&offset_pitch=4",
               content=SPEECH.read_bytes(), headers={"content-type": "audio/wav"})
    assert r.status_code == 200, r.text
    got = _npz(r.content)
    rv = next(v for k, v in got.items() if v.ndim == 2 and v.shape[1] == 3)
    np.testing.assert_allclose(rv, want.rotvec, atol=1e-12)


def test_offline_with_a_lookahead_is_synthesizes_with_it():
    """``lookahead_ms`` reads ahead as ``synthesize(lookahead_ms=...)`` does; out of its range, or
    for a model that is not live, 400 ``bad_parameter``."""
    from headmotion.types import Audio

    x = speech_f32()
    want = synthesize(Audio(x, 16000), registry().models["stream"], lookahead_ms=200)[0]
    with client(names=("stream", "default")) as cl:
        q = "/v1/motion?model=stream&encoding=f32le&sample_rate=16000&format=npz"
        r = cl.post(q + "&lookahead_ms=200", content=x.tobytes())
        assert r.status_code == 200, r.text
        rv = next(v for v in _npz(r.content).values() if v.ndim == 2 and v.shape[1] == 3)
        np.testing.assert_allclose(rv, want.rotvec, atol=1e-12)
        for bad in (q + "&lookahead_ms=2000", q.replace("model=stream", "model=default") + "&lookahead_ms=200"):
            r = cl.post(bad, content=x.tobytes())
            assert r.status_code == 400 and r.json()["error"] == "bad_parameter", r.text
            assert "lookahead_ms" in r.json()["detail"]


def test_json_default_and_samples(c):
    model = registry().models["stream"]
    audio = load_audio(SPEECH)
    r = c.post("/v1/motion?model=stream&seed=5&samples=2", content=SPEECH.read_bytes(),
               headers={"content-type": "audio/wav"})
    assert r.status_code == 200 and r.headers["content-type"].startswith("application/json")
    docs = r.json()["samples"]
    assert len(docs) == 2
    for k, doc in enumerate(docs):
        want = model.predict(audio, seed=5 + k).rotvec
        np.testing.assert_allclose(np.array(doc["frames"]), want, atol=1e-9)
    assert not np.allclose(docs[0]["frames"], docs[1]["frames"])  # two seeds, two motions


def test_raw_pcm_equals_file(c):
    x = speech_f32()
    pcm = (np.clip(x, -1, 1) * 32767).astype("<i2").tobytes()
    r = c.post("/v1/motion?model=stream&format=npz&encoding=s16le&sample_rate=16000", content=pcm,
               headers={"content-type": "application/octet-stream"})
    assert r.status_code == 200, r.text
    from headmotion.types import Audio

    want = registry().models["stream"].predict(Audio(np.frombuffer(pcm, "<i2").astype(np.float32) / 32768, 16000), seed=0)
    rv = next(v for v in _npz(r.content).values() if v.ndim == 2 and v.shape[1] == 3)
    np.testing.assert_allclose(rv, want.rotvec, atol=1e-12)


@pytest.mark.parametrize("fmt,head", [("bvh", b"HIERARCHY"), ("csv", None), ("glb", b"glTF"), ("gltf", b"{")])
def test_formats(c, fmt, head):
    r = c.post(f"/v1/motion?model=stream&format={fmt}", content=SPEECH.read_bytes(),
               headers={"content-type": "audio/wav"})
    assert r.status_code == 200, r.text
    if head is not None:
        assert r.content.startswith(head)
    else:
        assert len(r.text.splitlines()) > 60  # one line per frame (2.8 s at 25 fps) and a header


def test_zip_of_samples_still_and_fps(c):
    r = c.post("/v1/motion?model=stream&format=bvh&samples=3", content=SPEECH.read_bytes(),
               headers={"content-type": "audio/wav"})
    assert r.headers["content-type"] == "application/zip"
    assert sorted(zipfile.ZipFile(io.BytesIO(r.content)).namelist()) == ["sample_1.bvh", "sample_2.bvh", "sample_3.bvh"]
    r = c.post("/v1/motion?model=stream&still=true&offset_yaw=10&fps=25", content=SPEECH.read_bytes(),
               headers={"content-type": "audio/wav"})
    doc = r.json()
    assert doc["fps"] == 25.0 and abs(len(doc["frames"]) - round(2.777 * 25)) <= 1
    frames = np.array(doc["frames"])
    assert np.ptp(frames, axis=0).max() < 1e-9  # still: every frame the same pose
    assert abs(np.linalg.norm(frames[0]) - np.radians(10)) < 1e-6


@pytest.mark.parametrize("query,ctype,body,status,kind", [
    ("model=nope", "audio/wav", None, 404, "unknown_model"),
    ("model=stream&gain=a,b", "audio/wav", None, 400, "bad_parameter"),
    ("model=stream&format=mp4", "audio/wav", None, 400, "bad_parameter"),
    ("model=stream&seed=-1", "audio/wav", None, 400, "bad_parameter"),
    ("model=stream&fps=0", "audio/wav", None, 400, "bad_parameter"),
    ("model=stream", "text/plain", None, 415, "bad_audio"),
    ("model=stream", "audio/wav", b"RIFF....WAVEnot audio", 400, "bad_audio"),
    ("model=stream", "audio/wav", b"", 400, "bad_audio"),
    ("model=stream&encoding=s16le&sample_rate=16000", "application/octet-stream", b"\x00\x01\x02", 400, "bad_audio"),
    ("model=stream&encoding=s16le", "application/octet-stream", b"\x00\x01", 400, "bad_parameter"),
])
def test_offline_errors(c, query, ctype, body, status, kind):
    r = c.post(f"/v1/motion?{query}", content=SPEECH.read_bytes() if body is None else body,
               headers={"content-type": ctype})
    assert r.status_code == status, r.text
    assert r.json()["error"] == kind and r.json()["detail"]
    assert "/tmp" not in r.json()["detail"]  # the server's temporary paths stay on the server


def test_size_and_duration_limits():
    with client(max_body_bytes=50_000) as cl:
        r = cl.post("/v1/motion?model=stream", content=SPEECH.read_bytes(), headers={"content-type": "audio/wav"})
        assert r.status_code == 413 and r.json()["error"] == "too_large"
    with client(max_audio_seconds=1.0) as cl:
        r = cl.post("/v1/motion?model=stream", content=SPEECH.read_bytes(), headers={"content-type": "audio/wav"})
        assert r.status_code == 413 and r.json()["error"] == "too_long" and "2.8 s" in r.json()["detail"]


def test_models_health_metrics_headers(c):
    assert c.get("/healthz").json() == {"status": "ok"}
    assert c.get("/readyz").json()["status"] == "ready"
    cards = c.get("/v1/models").json()["models"]
    (card,) = cards
    assert card["name"] == "stream" and card["system"] == "motion-match" and card["sample_rate"] == 16000
    assert card["frame_rate"] == 25.0 and "causal" in card["capabilities"] and 0 < card["latency_ms"] < 200
    r = c.get("/metrics")
    assert "headmotion_requests_total" in r.text and "headmotion_frame_latency_seconds_bucket" in r.text
    assert r.headers["x-frame-options"] == "DENY" and r.headers["cache-control"] == "no-store"
    assert "frame-ancestors 'none'" in r.headers["content-security-policy"]
    schema = c.get("/openapi.json").json()
    assert "/v1/motion" in schema["paths"]
    assert "cdn.jsdelivr.net" in c.get("/docs").headers["content-security-policy"]


def test_example_page_and_its_files(c):
    page = c.get("/v1/example")
    assert page.status_code == 200 and "/v1/example/static/example.js" in page.text
    assert "<script>" not in page.text  # no inline script: the page runs under the CSP
    for path in ("/v1/example/static/example.js", "/v1/example/static/client/index.js",
                 "/v1/example/static/client/capture-worklet.js",
                 "/v1/example/viewer/viewer.js", "/v1/example/viewer/head_mesh.bin"):
        assert c.get(path).status_code == 200, path


def test_host_and_origin_guard(c):
    assert c.get("/healthz", headers={"host": "evil.example"}).status_code == 400
    r = c.post("/v1/motion?model=stream", content=SPEECH.read_bytes(),
               headers={"content-type": "audio/wav", "origin": "https://evil.example"})
    assert r.status_code == 403 and "cross-origin" in r.json()["detail"]
    r = c.post("/v1/motion?model=stream", content=SPEECH.read_bytes(),
               headers={"content-type": "audio/wav", "origin": "http://localhost"})
    assert r.status_code == 200


def test_default_model_is_offline_default():
    with client(names=("default", "stream")) as cl:
        r = cl.post("/v1/motion?format=npz&seed=1", content=SPEECH.read_bytes(), headers={"content-type": "audio/wav"})
        assert r.status_code == 200 and r.headers["x-headmotion-model"] == "default"
        want = registry("default", "stream").models["default"].predict(load_audio(SPEECH), seed=1)
        rv = next(v for v in _npz(r.content).values() if v.ndim == 2 and v.shape[1] == 3)
        np.testing.assert_allclose(rv, want.rotvec, atol=1e-9)
        assert json.loads(cl.get("/v1/models").text)["default_offline"] == "default"


def test_container_sniffed_when_the_request_does_not_say():
    """A body sent without a Content-Type (or with curl's form default) is recognised from its
    first bytes; an unknown body still gets the clear 415."""
    from headmotion.serve.offline import sniff_container

    assert sniff_container(b"RIFF\x00\x00\x00\x00WAVEfmt ") == ".wav"
    assert sniff_container(b"fLaC\x00") == ".flac"
    assert sniff_container(b"OggS\x00") == ".ogg"
    assert sniff_container(b"ID3\x04") == ".mp3"
    assert sniff_container(b"garbage") is None
