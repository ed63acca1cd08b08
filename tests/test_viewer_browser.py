"""The browser viewer: server endpoints, the bundled static files, and end to end in
Debian's chromium driven by Playwright — the canvas renders, the head turns the right way, and the
drawn frame follows the audio clock.

Browser tests skip with a reason when Playwright or chromium is missing.  Chromium runs headless
with ``--no-sandbox --disable-gpu``; WebGL then runs on SwiftShader (the CPU).
"""

from __future__ import annotations

import base64
import io
import math
import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from headmotion.types import Audio, Motion
from headmotion.web import STATIC_DIR

FPS = 25.0
DUR = 8.0


def _yaw_motion():
    t = np.arange(int(DUR * FPS)) / FPS
    rv = np.zeros((len(t), 3))
    rv[:, 1] = 0.4 * np.sin(2 * np.pi * 0.5 * t)  # +0.4 rad at 0.5 s, -0.4 rad at 1.5 s
    return Motion(rv, FPS)


def _audio():
    sr = 16000
    t = np.arange(int(DUR * sr)) / sr
    return Audio((0.2 * np.sin(2 * np.pi * 220 * t)).astype(np.float32), sr)


# -- static files and server (no browser) ------------------------------------------------------
def test_static_files_are_built():
    js = (STATIC_DIR / "viewer.js").read_text()
    assert "mountViewer" in js and "createViewer" in js
    # three.js is bundled in: no bare "three" import and no CDN at run time
    assert 'from"three"' not in js and "from 'three'" not in js and 'from "three"' not in js
    assert "unpkg.com" not in js and "jsdelivr" not in js and "cdnjs" not in js
    # the committed mesh is what the code builds now
    from headmotion.render.mesh import build_head_mesh, mesh_from_bytes
    from headmotion.web.build_assets import MESH_FILE, WEB_DETAIL

    committed = mesh_from_bytes(MESH_FILE.read_bytes())
    fresh = build_head_mesh(detail=WEB_DETAIL)
    assert [p.name for p in committed.parts] == [p.name for p in fresh.parts]
    for a, b in zip(committed.parts, fresh.parts):
        assert a.n_vertices == b.n_vertices
        np.testing.assert_allclose(a.positions, b.positions, atol=1e-5)
    pkg = Path(STATIC_DIR).parent / "js"
    assert (pkg / "package.json").is_file() and (pkg / "package-lock.json").is_file()


def test_server_endpoints(tmp_path):
    from fastapi.testclient import TestClient

    from headmotion.web.server import _write_wav, create_app

    m = _yaw_motion()
    wav = _write_wav(_audio(), str(tmp_path))
    client = TestClient(create_app([m, m.scaled(0.0)], labels=["truth", "still"], audio_path=wav))
    s = client.get("/api/session").json()
    assert [x["label"] for x in s["motions"]] == ["truth", "still"] and s["audioUrl"] == "/audio.wav"
    d = client.get("/motion/0.json").json()
    assert d["fps"] == FPS and len(d["rotvec"]) == len(m)
    np.testing.assert_allclose(d["rotvec"], m.rotvec, atol=1e-6)
    assert client.get("/motion/5.json").status_code == 404
    r = client.get("/audio.wav", headers={"Range": "bytes=0-99"})
    assert r.status_code == 206 and len(r.content) == 100  # range requests: seeking works
    assert "mountViewer" in client.get("/").text
    assert client.get("/viewer/viewer.js").status_code == 200
    assert client.get("/viewer/head_mesh.bin").content[:4] == b"HMSH"


# -- in a real browser -------------------------------------------------------------------------
CHROMIUM = os.environ.get("HEADMOTION_CHROMIUM", "/usr/bin/chromium")


@pytest.fixture(scope="module")
def browser():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed (pip install playwright)")
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"chromium not found at {CHROMIUM} (apt-get install chromium)")
    with sync_playwright() as p:
        b = p.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--headless",
                  "--autoplay-policy=no-user-gesture-required", "--use-angle=swiftshader",
                  "--enable-unsafe-swiftshader"],
        )
        yield b
        b.close()


@pytest.fixture(scope="module")
def page(browser):
    from headmotion.web.server import running_server

    m = _yaw_motion()
    with running_server([m, m.scaled(0.0)], labels=["truth", "still"], audio=_audio()) as url:
        pg = browser.new_page(viewport={"width": 1100, "height": 600})
        errors = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(url)
        pg.wait_for_function("document.body.dataset.ready", timeout=60000)
        assert pg.evaluate("document.body.dataset.ready") == "1", pg.inner_text("#error")
        yield pg
        assert not errors, errors
        pg.close()


def _canvas(pg) -> np.ndarray:
    from PIL import Image

    url = pg.evaluate("headmotionViewer.renderNow(), document.querySelector('.hm-viewer canvas').toDataURL('image/png')")
    img = Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGB")
    return np.asarray(img)


def _mask_x(cell: np.ndarray) -> float:
    ys, xs = np.nonzero(cell.max(axis=2) < 12)
    assert len(xs) > 200, "no black boxes over the eyes and mouth drawn"
    return xs.mean()


@pytest.mark.browser
def test_canvas_renders_and_head_turns_the_right_way(page):
    page.evaluate("headmotionViewer.pause(), headmotionViewer.seek(0)")
    img = _canvas(page)
    h, w, _ = img.shape
    bg = img[2, w // 2 - 2]  # top middle: background
    assert np.mean(np.any(np.abs(img.astype(int) - bg) > 12, axis=2)) > 0.15  # not blank
    left, right = img[:, : w // 2], img[:, w // 2:]
    x_rest, x_still = _mask_x(left), _mask_x(right)
    assert abs(x_rest - w / 4) < 0.03 * w  # faces the camera
    page.evaluate("headmotionViewer.seek(0.5)")     # yaw +0.4: nose to the speaker's left = image right
    img_pos = _canvas(page)
    page.evaluate("headmotionViewer.seek(1.5)")     # yaw -0.4
    img_neg = _canvas(page)
    s = page.evaluate("headmotionViewer.getState()")
    assert s["frames"] == [37, 37] and abs(s["rotvec"][0][1] + 0.4) < 1e-3
    assert _mask_x(img_pos[:, : w // 2]) > x_rest + 0.02 * w
    assert _mask_x(img_neg[:, : w // 2]) < x_rest - 0.02 * w
    # the still head does not move
    assert abs(_mask_x(img_neg[:, w // 2:]) - x_still) < 1.0


@pytest.mark.browser
def test_playback_follows_the_audio_clock(page):
    page.evaluate("headmotionViewer.pause(), headmotionViewer.seek(0)")
    page.click(".hm-play")  # the play button starts the audio
    samples = []
    deadline = time.monotonic() + 20
    while len(samples) < 6 and time.monotonic() < deadline:
        time.sleep(0.3)
        s = page.evaluate("""(() => {
            const v = headmotionViewer; const t0 = v.audio.currentTime; v.renderNow();
            const s = v.getState(); return {t0, t1: v.audio.currentTime, frame: s.rendered.frames[0],
                rt: s.rendered.time, yaw: s.rotvec[0][1], playing: s.playing, paused: v.audio.paused}; })()""")
        if s["t1"] >= DUR - 0.2:
            break
        samples.append(s)
    assert len(samples) >= 3
    assert all(s["playing"] and not s["paused"] for s in samples)
    times = [s["t1"] for s in samples]
    assert times[-1] > times[0] + 0.2  # the audio plays
    for s in samples:
        # the drawn frame is the one the audio clock points at (< 1 frame apart)
        assert math.floor(s["t0"] * FPS + 1e-6) <= s["frame"] <= math.floor(s["t1"] * FPS + 1e-6)
        assert abs(s["rt"] * FPS - s["frame"]) < 1
    assert len({round(s["yaw"], 4) for s in samples}) >= 3  # the head moves over time
    if page.evaluate("headmotionViewer.getState().playing"):
        page.click(".hm-play")  # pause (unless the clip already ended on a very slow machine)
    s = page.evaluate("(() => { const v = headmotionViewer; v.renderNow(); return {...v.getState(), t: v.audio.currentTime, paused: v.audio.paused}; })()")
    assert s["paused"] and not s["playing"]
    assert s["rendered"]["frames"][0] == min(len(_yaw_motion()) - 1, math.floor(s["t"] * FPS + 1e-6))
