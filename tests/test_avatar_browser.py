"""The avatar page of ``headmotion serve`` (``/v1/avatar``): its files are the package's, and in
headless Chromium with a fake microphone playing real speech (``?input=mic&autostart=1``) the VRM
avatar's head bone takes the stream's frames — each frame put on the bones equals, within 0.5°,
``headmotion synth -m stream`` (the library's synthesize with the ``stream`` model) on the audio the
page sent, at the same frame — and the page shows a latency.  Browser tests skip with a reason
without Playwright or Chromium."""

from __future__ import annotations

import base64
import time

import numpy as np
import pytest
from conftest import CHROMIUM
from serve_helpers import ROOT, registry

SPEECH = ROOT / "examples" / "speech" / "speech_female.wav"
#: the flags Chromium runs with (a headless machine without a GPU: WebGL drawn by SwiftShader)
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--autoplay-policy=no-user-gesture-required", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream"]


def _wait(page, expr: str, timeout_s: float = 60.0) -> None:
    """Poll ``expr`` (the server's CSP has no 'unsafe-eval', which ``wait_for_function`` needs)."""
    end = time.monotonic() + timeout_s
    while not page.evaluate(f"Boolean({expr})"):
        if time.monotonic() > end:
            raise TimeoutError(f"timed out waiting for {expr}")
        page.wait_for_timeout(50)


def test_avatar_page_and_its_files_are_served():
    from serve_helpers import client

    c = client()
    page = c.get("/v1/avatar")
    assert page.status_code == 200 and "text/html" in page.headers["content-type"]
    assert "/v1/avatar/static/avatar-page.js" in page.text
    assert "'unsafe-inline'" not in page.headers["content-security-policy"]
    for path in ("static/avatar.js", "static/avatar-page.js", "static/avatar.vrm", "static/avatar.css",
                 "client/index.js", "client/capture-worklet.js"):
        r = c.get(f"/v1/avatar/{path}")
        assert r.status_code == 200, path
    js = c.get("/v1/avatar/static/avatar.js").text
    assert "@pixiv/three-vrm" in js[:4000] and "VRMC_vrm" in js  # three-vrm is bundled in
    for cdn in ("unpkg.com", "jsdelivr", "cdnjs", "esm.sh"):
        assert cdn not in js
    assert c.get("/v1/avatar/static/avatar.vrm").content[:4] == b"glTF"


def _run_page(playwright, query: str, tmp_path, frames: int = 150, app=None, begin=None) -> dict:
    """Open ``/v1/avatar?QUERY`` on a real server (``app``, by default ``headmotion serve``'s) with
    the fake microphone playing SPEECH; the page's state once ``frames`` frames have come, with the
    audio it sent.  ``begin``: (a function, its argument) evaluated once the page is ready."""
    from headmotion.serve.app import create_app
    from headmotion.serve.config import ServeConfig
    from headmotion.web.server import running_app

    app = app or create_app(ServeConfig(), registry=registry())
    with running_app(app, ws="websockets-sansio") as url, playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=[*FLAGS, f"--use-file-for-fake-audio-capture={SPEECH}"])
        try:
            pg = b.new_page(viewport={"width": 700, "height": 760})
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.on("console", lambda m: m.type == "error" and errors.append(m.text))
            pg.goto(url + "v1/avatar?" + query)
            _wait(pg, "document.body.dataset.ready")
            assert pg.evaluate("document.body.dataset.ready") == "1", pg.inner_text("#error")
            if begin is not None:
                pg.evaluate(*begin)
            _wait(pg, f"window.headmotionAvatar.frames >= {frames} || window.headmotionAvatar.error")
            pg.locator("#avatar canvas").screenshot(path=str(tmp_path / "avatar.png"))
            st = pg.evaluate("({shown: headmotionAvatar.shown, ready: headmotionAvatar.ready, "
                             "error: headmotionAvatar.error, status: headmotionAvatar.status, "
                             "now: headmotionAvatar.headRotation(), audio: headmotionAvatar.sentAudio(), "
                             "delay: headmotionAvatar.audioDelayS(), "
                             "stats: document.getElementById('stats').textContent})")
        finally:
            b.close()
    st["errors"] = errors
    pcm = np.frombuffer(base64.b64decode(st["audio"]["base64"]), "<i2")
    st["sent"] = pcm.astype(np.float32) / 32768.0
    return st


def _check_bones(st, ref) -> tuple[np.ndarray, np.ndarray]:
    """Frames on the bones in order, each within 0.5° of the reference motion at the same frame;
    returns the frame numbers and the differences (degrees)."""
    from headmotion.rotations import rotvec_to_pitch_yaw_roll

    shown = st["shown"]
    idx = np.array([s["frame"] for s in shown])
    assert list(idx) == sorted(set(idx)) and len(idx) > 50  # in order, none twice
    np.testing.assert_allclose(st["now"], shown[-1]["rotation"], atol=1e-9)  # the bones hold the newest frame
    ref_deg = rotvec_to_pitch_yaw_roll(ref.rotvec, degrees=True)
    assert idx.max() < len(ref)
    got = np.array([s["rotation"] for s in shown])
    err = np.abs(got - ref_deg[idx]).max(axis=1)
    assert err.max() <= 0.5, (err.max(), int(idx[err.argmax()]))
    assert np.ptp(got, axis=0).max() > 1.0  # the head moved (degrees)
    return idx, err


@pytest.mark.browser
@pytest.mark.timeout(240)
def test_head_bone_follows_the_stream_from_a_fake_microphone(playwright, tmp_path):
    import headmotion
    from headmotion.types import Audio

    st = _run_page(playwright, "input=mic&autostart=1&record=1", tmp_path)
    assert not st["errors"], st["errors"]
    assert st["error"] is None and st["status"].startswith("streaming (microphone): stream")
    rate = int(st["audio"]["sampleRate"])
    (ref,) = headmotion.synthesize(Audio(st["sent"], rate), model="stream")  # headmotion synth -m stream
    idx, err = _check_bones(st, ref)

    lat = np.array([s["latencyMs"] for s in st["shown"][5:]], dtype=float)
    assert np.all(np.isfinite(lat))
    # a frame cannot reach the bones before its audio and the model's lookahead were had
    assert np.median(lat) >= st["ready"]["latency_ms"] - 5, np.median(lat)
    assert "latency median" in st["stats"] and "p95" in st["stats"]
    print(f"{len(idx)} frames on the bones, largest difference from synth {err.max():.4f} deg; latency from the "
          f"audio to the bone: median {np.median(lat):.0f} ms, p95 {np.percentile(lat, 95):.0f} ms")


@pytest.mark.browser
@pytest.mark.timeout(240)
def test_with_a_lookahead_a_file_is_heard_that_much_later_and_the_bones_read_ahead(playwright, tmp_path):
    """``?lookahead_ms=220`` and a file: the page plays the file aloud through a delay of the whole
    frames read ahead (200 ms at 25 fps), the stream's latency has grown by as much, and the bones
    take ``headmotion synth -m stream --lookahead-ms 220``'s frames of the audio sent."""
    import headmotion
    from headmotion.types import Audio

    wav = base64.b64encode(SPEECH.read_bytes()).decode()
    started = ("(b64) => { const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0)); "
               "headmotionAvatar.start(new File([bytes], 'speech.wav', {type: 'audio/wav'})); return true; }")
    st = _run_page(playwright, "record=1&lookahead_ms=220", tmp_path, frames=100, begin=(started, wav))
    assert not st["errors"], st["errors"]
    assert st["error"] is None and st["status"].startswith("streaming (file): stream")
    assert st["delay"] == pytest.approx(0.2, abs=1e-6)
    base = registry().models["stream"].stream(seed=0).latency_ms
    assert st["ready"]["lookahead_ms"] == 220 and st["ready"]["latency_ms"] == pytest.approx(base + 200)
    rate = int(st["audio"]["sampleRate"])
    (ref,) = headmotion.synthesize(Audio(st["sent"], rate), model="stream", lookahead_ms=220)
    _check_bones(st, ref)


@pytest.mark.browser
@pytest.mark.timeout(240)
def test_head_listens_to_the_fake_microphone(playwright, tmp_path):
    """``?role=listen``: the microphone is the other party (hear messages), the avatar's own channel
    silence; the bones take ``synth SILENCE --hear SENT``'s frames."""
    _check_listening(_run_page(playwright, "input=mic&autostart=1&record=1&role=listen", tmp_path, frames=100))


@pytest.mark.browser
@pytest.mark.timeout(240)
def test_view_live_serves_the_avatar_page(playwright, tmp_path):
    """``headmotion view --live`` answers ``/v1/avatar`` and its ``/v1/stream``: the listening page
    there takes the same frames as on ``headmotion serve``."""
    from headmotion.synthesis import load_model
    from headmotion.web.live import create_live_app

    app = create_live_app(load_model("stream"), model_path="stream")
    _check_listening(_run_page(playwright, "input=mic&autostart=1&record=1&role=listen", tmp_path, frames=100,
                               app=app))


def _check_listening(st) -> None:
    """The page listened (hear messages) and its bones took ``synth SILENCE --hear SENT``'s frames."""
    import headmotion
    from headmotion.types import Audio

    assert not st["errors"], st["errors"]
    assert st["error"] is None and st["status"].startswith("listening to (microphone)")
    assert st["ready"]["hear"]["sample_rate"] == st["audio"]["sampleRate"]
    rate = int(st["audio"]["sampleRate"])
    silence = Audio(np.zeros_like(st["sent"]), rate)
    (ref,) = headmotion.synthesize(silence, model="stream", hear=Audio(st["sent"], rate))
    _check_bones(st, ref)
