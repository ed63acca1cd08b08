"""The models a ``headmotion serve`` worker offers: the shipped names, a ``--models`` folder, the
readiness answer while loading fails, and the controls of a stream (still head, gain)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from serve_helpers import WS, client, read_until_close, start

from headmotion.errors import ParameterError
from headmotion.serve import engine
from headmotion.synthesis import Controls


def test_models_folder(tmp_path):
    shutil.copy(engine.SHIPPED["stream"], tmp_path / "mine.hmz")
    (tmp_path / "mine.md").write_text("# Card\n\nMy own streaming head.\n")
    files = engine.model_files(tmp_path)
    assert set(files) == {"default", "stream", "mine"}
    from headmotion.serve.models import Registry

    reg = Registry({"mine": files["mine"]}).load_all()
    assert reg.cards["mine"]["card"] == "My own streaming head." and reg.cards["mine"]["streams"]
    with pytest.raises(ParameterError, match="not a folder"):
        engine.model_files(tmp_path / "mine.md")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ParameterError, match="no .hmz"):
        engine.model_files(empty)


def test_readyz_says_why_loading_failed(tmp_path):
    import time
    import warnings

    from headmotion.serve.app import create_app
    from headmotion.serve.models import Registry

    bad = tmp_path / "broken.hmz"
    bad.write_bytes(b"not a model")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from fastapi.testclient import TestClient
    with TestClient(create_app(registry=Registry({"broken": bad})), base_url="http://localhost") as c:
        for _ in range(100):
            r = c.get("/readyz")
            if r.json()["status"] != "loading":
                break
            time.sleep(0.05)
        assert r.status_code == 503 and r.json()["status"] == "failed" and "broken.hmz" in r.json()["error"]
        m = c.get("/v1/models")
        assert m.status_code == 503 and m.json()["error"] == "not_ready"


def test_controls_parse():
    c = engine.Controls.parse(gain="1.2", offset_degrees="0,10,0", gain_pyr=(None, 0.5, None), still=False, fps=25)
    assert engine.Controls is Controls  # one class for every front end
    assert c.gain == (1.2, 0.5, 1.2) and np.allclose(c.offset, (0, np.radians(10), 0)) and c.fps == 25.0
    for bad in ({"gain": "a"}, {"gain": "1,2"}, {"fps": 0}, {"fps": 1001}, {"offset_degrees": [1, 2]}):
        with pytest.raises(ParameterError):
            engine.Controls.parse(**bad)


def test_stream_still_and_gain():
    with client() as c:
        def frames(**kw):
            with c.websocket_connect(WS) as ws:
                ws.send_text(start(encoding="f32le", **kw))
                ws.receive_text()
                rng = np.random.default_rng(0)
                ws.send_bytes((0.1 * rng.standard_normal(32000)).astype("<f4").tobytes())
                ws.send_text('{"type": "end"}')
                out = read_until_close(ws)
            docs = [json.loads(m["text"]) for m in out if m.get("text")]
            return np.array([f["pitch_yaw_roll_deg"] for d in docs if d["type"] == "frames" for f in d["frames"]])

        still = frames(still=True, offset=[0, 10, 0])
        assert len(still) == 50 and np.allclose(still, [0, 10, 0], atol=1e-3)
        base, flat = frames(), frames(gain=[1, 0, 1])
        assert np.ptp(base[:, 1]) > 1.0 and np.ptp(flat[:, 1]) < 1e-3  # yaw held at the mean pose
        held = frames(amount=0)  # by choice: the motion-matching model holds its mean pose
        assert len(held) == 50 and np.ptp(held, axis=0).max() < 1e-6
