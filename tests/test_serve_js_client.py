"""The browser client (``@headmotion/client``, ``serve/static/client/``) in headless Chromium against a
real server: ``motion(file)`` gives the library's motion for the file, ``stream(chunks)`` the
library's stream for the same samples (every frame, in order), refusals arrive as
``HeadmotionError`` with the server's kind, and the package's files are what it declares.  Skips
with a reason without Playwright or Chromium."""

from __future__ import annotations

import base64
import json

import numpy as np
import pytest
from conftest import CHROMIUM
from serve_helpers import ROOT, SPEECH, registry, speech_f32

from headmotion.io import load_audio
from headmotion.synthesis import synthesize

pytestmark = [pytest.mark.browser, pytest.mark.timeout(180)]
CLIENT = ROOT / "src" / "headmotion" / "serve" / "static" / "client"


def test_package_layout():
    import headmotion

    pkg = json.loads((CLIENT / "package.json").read_text())
    assert pkg["type"] == "module" and pkg["exports"]["."] == "./index.js"
    assert pkg["version"] == headmotion.__version__
    for f in pkg["files"]:
        assert (CLIENT / f).is_file(), f
    src = (CLIENT / "index.js").read_text()
    assert "export async function motion(" in src and "export async function* stream(" in src
    assert "https://" not in src.replace("https:", "")  # nothing fetched from elsewhere


@pytest.fixture(scope="module")
def page_at():
    """(evaluate, url): a Chromium page on the server's example page (same origin, its CSP)."""
    import shutil

    from headmotion.serve.app import create_app
    from headmotion.serve.config import ServeConfig
    from headmotion.serve.protocol import WS_PROTOCOL
    from headmotion.web.server import running_app

    sync_playwright = pytest.importorskip("playwright.sync_api", reason="playwright is not installed").sync_playwright
    if not ((ROOT / CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"chromium not found at {CHROMIUM}")
    app = create_app(ServeConfig(), registry=registry())
    with running_app(app, ws=WS_PROTOCOL) as url, sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox", "--disable-gpu", "--headless"])
        try:
            pg = b.new_page()
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.goto(url + "v1/example")
            yield pg, errors
        finally:
            b.close()


IMPORT = 'const hm = await import("/v1/example/static/client/index.js");'


def test_motion_of_a_file_is_the_librarys(page_at):
    pg, errors = page_at
    wav = base64.b64encode(SPEECH.read_bytes()).decode()
    doc = pg.evaluate("async (wav) => {" + IMPORT + """
        const bytes = Uint8Array.from(atob(wav), (c) => c.charCodeAt(0));
        return await hm.motion(new Blob([bytes], { type: "audio/wav" }), { model: "stream", seed: 3, gain: [1.2, 0.5, 1] });
    }""", wav)
    want = synthesize(load_audio(SPEECH), registry().models["stream"], seed=3, gain=(1.2, 0.5, 1.0))[0]
    np.testing.assert_allclose(np.array(doc["frames"]), want.rotvec, atol=1e-9)
    assert not errors, errors


def test_stream_of_chunks_is_the_librarys(page_at):
    pg, errors = page_at
    x = speech_f32()
    got = pg.evaluate("async (samples) => {" + IMPORT + """
        const x = Float32Array.from(samples), chunks = [];
        for (let i = 0; i < x.length; i += 160) chunks.push(x.subarray(i, i + 160));
        let ready = null;
        const out = [];
        for await (const b of hm.stream(chunks, { sampleRate: 16000, encoding: "f32le", seed: 1,
                                                  onReady: (r) => { ready = r; } })) {
            for (const f of b.frames) out.push([f.frame, f.rotvec]);
        }
        return { ready, out };
    }""", x.tolist())
    assert got["ready"]["model"] == "stream"
    assert [f[0] for f in got["out"]] == list(range(len(got["out"])))  # in order, none lost or twice
    rv = np.array([f[1] for f in got["out"]])
    s = registry().models["stream"].stream(seed=1)
    want = np.vstack([s.push(x).rotvec, s.flush().rotvec])
    assert rv.shape == want.shape
    np.testing.assert_allclose(rv, want, atol=1e-6)
    assert not errors, errors


def test_stream_with_a_lookahead_is_synthesizes_with_it(page_at):
    """``lookaheadMs`` goes into the start message: the frames are ``synthesize(model="stream",
    lookahead_ms=...)``'s and the ready message says the lookahead and the longer latency."""
    from headmotion.types import Audio

    pg, errors = page_at
    x = speech_f32()
    got = pg.evaluate("async (samples) => {" + IMPORT + """
        const x = Float32Array.from(samples), chunks = [];
        for (let i = 0; i < x.length; i += 320) chunks.push(x.subarray(i, i + 320));
        let ready = null;
        const out = [];
        for await (const b of hm.stream(chunks, { sampleRate: 16000, encoding: "f32le", lookaheadMs: 280,
                                                  onReady: (r) => { ready = r; } })) {
            for (const f of b.frames) out.push(f.rotvec);
        }
        return { ready, out };
    }""", x.tolist())
    want = synthesize(Audio(x, 16000), registry().models["stream"], lookahead_ms=280)[0].rotvec
    np.testing.assert_allclose(np.array(got["out"]), want, atol=1e-6)
    base = registry().models["stream"].stream(seed=0).latency_ms
    assert got["ready"]["lookahead_ms"] == 280 and got["ready"]["latency_ms"] == pytest.approx(base + 280)
    assert not errors, errors


@pytest.mark.parametrize("call,kind", [
    ('hm.motion(new Blob([new Uint8Array(8)], { type: "audio/wav" }), { model: "stream", gain: -1 })', "bad_parameter"),
    ('(async () => { for await (const b of hm.stream([new Float32Array(160)], { sampleRate: 16000, model: "nope" })) {} })()',
     "unknown_model"),
    ('(async () => { for await (const b of hm.stream([new Float32Array(160)], { sampleRate: 16000, gain: 11 })) {} })()',
     "bad_start"),
    ('(async () => { for await (const b of hm.stream([new Float32Array(160)], { sampleRate: 16000, lookaheadMs: 2000 })) {} })()',
     "bad_start")])
def test_refusals_are_errors_with_the_servers_kind(page_at, call, kind):
    pg, _ = page_at
    got = pg.evaluate("async () => {" + IMPORT + f"""
        try {{ await {call}; return null; }}
        catch (e) {{ return {{ name: e.name, kind: e.kind, detail: e.detail, status: e.status, code: e.code }}; }}
    }}""")
    assert got is not None and got["name"] == "HeadmotionError" and got["kind"] == kind and got["detail"], got
    assert got["status"] == 400 if kind == "bad_parameter" else got["code"] == 1008


def test_stream_interrupt_settles_the_head(page_at):
    """``interrupt`` (an AbortSignal) aborted once 30 frames came: the server drops the frames not
    yet final and settles from the last one sent over ``settle`` 0.4 s (10 frames at 25 fps): the
    last frame is the rest pose, and the stream ends without an error."""
    pg, errors = page_at
    x = speech_f32()
    got = pg.evaluate("async (samples) => {" + IMPORT + """
        const x = Float32Array.from(samples), ctl = new AbortController();
        async function* slow() {  // 20 ms of audio every 5 ms: the cut comes before the audio ends
            for (let i = 0; i < x.length; i += 320) { yield x.subarray(i, i + 320); await new Promise((r) => setTimeout(r, 5)); }
        }
        const out = [];
        for await (const b of hm.stream(slow(), { sampleRate: 16000, encoding: "f32le", settle: 0.4, interrupt: ctl.signal })) {
            for (const f of b.frames) out.push([f.frame, f.rotvec]);
            if (out.length >= 30) ctl.abort();
        }
        return out;
    }""", x.tolist())
    frames = [f[0] for f in got]
    full = len(x) / 16000 * 25
    assert frames[-1] + 1 < full  # cut off before the speech's end
    np.testing.assert_allclose(got[-1][1], 0.0, atol=1e-6)  # settled to rest
    last = frames[-1]
    assert frames[-10:] == list(range(last - 9, last + 1))  # the settling's 10 frames, in order
    assert not errors, errors
