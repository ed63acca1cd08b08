"""The listening-test HTTP API in-process: the participant flow, bad input rejected with 4xx and
nothing stored, no going back, blind stimuli, admin token, stimulus paths confined to the test."""

from __future__ import annotations

import os
import shutil
import warnings

import pytest

from headmotion.listening.app import create_app
from headmotion.listening.config import load_config

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

ADMIN = {"Authorization": "Bearer tok"}


@pytest.fixture
def make_client(tmp_path, examples_dir):
    d = tmp_path / "t"
    shutil.copytree(examples_dir / "listening", d, ignore=shutil.ignore_patterns("results"))

    def make(name="config.yaml"):
        cfg = load_config(d / name)
        app = create_app(cfg, database_url=f"sqlite:///{tmp_path / (name + '.sqlite')}",
                         admin_token="tok", allowed_hosts=["testserver"])
        return TestClient(app), app

    return make


def _register(c, demo=True):
    tok = c.post("/api/participants", json={"consent": True}).json()["token"]
    if demo:
        r = c.post(f"/api/p/{tok}/demographics",
                   json={"answers": {"native_language": "yes", "listening": "speakers",
                                     "gender": "male", "age": None}})
        assert r.status_code == 200, r.text
    assert c.post(f"/api/p/{tok}/start").status_code == 200
    return tok


def _n_answers(app):
    return app.state.db.count_answers()


def test_flow_and_no_going_back(make_client):
    c, app = make_client()
    assert c.post("/api/participants", json={"consent": False}).status_code == 400
    tok = c.post("/api/participants", json={"consent": True}).json()["token"]
    st = c.get(f"/api/p/{tok}/state").json()
    assert st["stage"] == "demographics" and "trial" not in st
    # trials cannot be answered before the questionnaire and instructions
    assert c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "rating": 3}).status_code == 409
    bad = c.post(f"/api/p/{tok}/demographics", json={"answers": {"native_language": "maybe"}})
    assert bad.status_code == 422 and "must be one of" in bad.text
    missing = c.post(f"/api/p/{tok}/demographics", json={"answers": {"native_language": "yes"}})
    assert missing.status_code == 422 and "please answer" in missing.text
    assert c.post(f"/api/p/{tok}/demographics", json={"answers": {
        "native_language": "yes", "listening": "speakers", "gender": "male"}}).status_code == 200
    assert c.post(f"/api/p/{tok}/start").status_code == 200
    st = c.get(f"/api/p/{tok}/state").json()
    assert st["trial"]["index"] == 0 and st["trial"]["phase"] == "training"
    assert st["progress"] == {"done": 0, "total": 19}
    r = c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "rating": 5, "response_ms": 1234})
    assert r.json() == {"stored": 1, "duplicate": False, "next_trial": 1, "done": False}
    # retry of the same answer: acknowledged, not stored twice; a changed rating: refused
    assert c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "rating": 5}).json()["duplicate"]
    assert c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "rating": 2}).status_code == 409
    # skipping ahead is refused
    assert c.post(f"/api/p/{tok}/answer", json={"trial_index": 5, "rating": 2}).status_code == 409
    assert _n_answers(app) == 1
    rows = app.state.db.answer_rows()
    assert rows[0]["value"] == 5.0 and rows[0]["phase"] == "training"
    assert rows[0]["response_ms"] == 1234


@pytest.mark.parametrize("body", [
    {"trial_index": 0, "rating": 8},
    {"trial_index": 0, "rating": 0},
    {"trial_index": 0, "rating": 3.5},
    {"trial_index": 0, "rating": "high"},
    {"trial_index": 0},
    {"trial_index": 0, "rating": 3, "choice": "left"},
    {"trial_index": 0, "ratings": {"A": 50}},
    {"trial_index": -1, "rating": 3},
    {"trial_index": 999, "rating": 3},
    {"trial_index": 0, "rating": 3, "participant": 2},
])
def test_bad_mos_answers_rejected_nothing_stored(make_client, body):
    c, app = make_client()
    tok = _register(c)
    r = c.post(f"/api/p/{tok}/answer", json=body)
    assert 400 <= r.status_code < 500, r.text
    assert _n_answers(app) == 0
    assert c.get(f"/api/p/{tok}/state").json()["progress"]["done"] == 0


def test_bad_mushra_answers_rejected_nothing_stored(make_client):
    c, app = make_client("mushra.yaml")
    tok = _register(c)
    slots = [s["label"] for s in c.get(f"/api/p/{tok}/state").json()["trial"]["slots"]]
    good = {s: 50.0 for s in slots}
    for ratings in ({**good, slots[0]: 100.5}, {**good, slots[0]: -1},
                    {**good, "E": 10}, {s: 1 for s in slots[:-1]}):
        r = c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "ratings": ratings})
        assert r.status_code == 422, ratings
    assert _n_answers(app) == 0
    assert c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "ratings": good}).status_code \
        == 200
    assert _n_answers(app) == len(slots)


def test_bad_ab_answer_and_forged_participant(make_client):
    c, app = make_client("ab.yaml")
    tok = _register(c, demo=False)
    assert c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "choice": "middle"}
                  ).status_code == 422
    for forged in ("x" * 32, "1", tok[:-1] + ("a" if tok[-1] != "a" else "b"), "x" * 200):
        r = c.post(f"/api/p/{forged}/answer", json={"trial_index": 0, "choice": "left"})
        assert r.status_code == 404
        assert c.get(f"/api/p/{forged}/state").status_code == 404
    assert _n_answers(app) == 0


def test_stimuli_blind_and_confined(make_client, tmp_path):
    c, app = make_client("mushra.yaml")
    tok = _register(c)
    trial = c.get(f"/api/p/{tok}/state").json()["trial"]
    ref = trial["reference"]
    m = c.get(ref["motion"])
    assert m.status_code == 200 and m.json()["fps"] == 25.0 and len(m.json()["rotvec"][0]) == 3
    a = c.get(ref["audio"])
    assert a.status_code == 200 and a.content[:4] == b"RIFF"
    assert "natural" not in repr(trial) and ".npz" not in repr(trial)
    for url in ("/stimuli/0123456789abcdef0123456789abcdef/audio", "/stimuli/../config.yaml/x",
                "/stimuli/..%2F..%2Fetc%2Fpasswd/audio", ref["motion"].replace("motion", "video"),
                "/stimuli/%2e%2e/audio", "/static/../config.py"):
        assert c.get(url).status_code == 404, url
    # a stimulus replaced by a symlink out of the test folder is refused
    cfg = app.state.cfg
    sid = next(iter(cfg.stimuli))
    target = cfg.stimuli[sid].audio
    secret_file = tmp_path / "secret.wav"
    secret_file.write_bytes(b"RIFFsecret")
    os.replace(target, str(target) + ".bak")
    os.symlink(secret_file, target)
    from headmotion.listening.plan import blind_id

    alias = blind_id(sid, "x", bytes.fromhex(app.state.db.get_meta("secret")))
    assert c.get(f"/stimuli/{alias}/audio").status_code == 404


def test_admin_requires_token_and_exports(make_client):
    c, app = make_client("ab.yaml")
    tok = _register(c, demo=False)
    c.post(f"/api/p/{tok}/answer", json={"trial_index": 0, "choice": "left"})
    for url in ("/api/admin/progress", "/api/admin/results.json", "/api/admin/results.csv"):
        assert c.get(url).status_code == 401
        assert c.get(url, headers={"Authorization": "Bearer wrong"}).status_code == 401
        assert c.get(url, headers=ADMIN).status_code == 200
    assert c.get("/api/admin/progress?token=tok").status_code == 401  # never in the URL
    assert c.get("/api/admin/progress", headers={"X-Admin-Token": "tok"}).json()["n_answers"] == 1
    doc = c.get("/api/admin/results.json", headers=ADMIN).json()
    assert doc["test"]["type"] == "ab" and len(doc["answers"]) == 1
    assert doc["answers"][0]["slot"] == "left"
    csv_text = c.get("/api/admin/results.csv", headers=ADMIN).text
    assert csv_text.splitlines()[0].startswith("participant,trial_index,phase,kind")
    # a participant's own state never carries answers of anyone
    other = _register(c, demo=False)
    assert "condition" not in c.get(f"/api/p/{other}/state").text
    assert c.get("/admin").status_code == 200 and c.get("/").status_code == 200


def test_attention_check_is_stored_and_scored(make_client):
    c, app = make_client()
    tok = _register(c)
    for i in range(19):
        t = c.get(f"/api/p/{tok}/state").json()["trial"]
        body = {"trial_index": i}
        if t["kind"] == "attention":
            assert t["options"] == ["red", "blue", "green"] and "answer" not in t
            body["choice"] = "red"
        else:
            body["rating"] = 4
        assert c.post(f"/api/p/{tok}/answer", json=body).status_code == 200
    assert c.get(f"/api/p/{tok}/state").json()["stage"] == "done"
    att = [r for r in app.state.db.answer_rows() if r["kind"] == "attention"]
    assert len(att) == 1 and att[0]["value"] == 0.0 and att[0]["other"] == "blue"
