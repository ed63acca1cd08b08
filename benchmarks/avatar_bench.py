"""``benchmarks/run.py --only avatar``: the avatar page (``/v1/avatar``) of a real ``headmotion
serve`` in headless Chromium, its fake microphone playing real speech
(``?input=mic&autostart=1``): the latency from the captured audio to the head bone — for each
frame put on the bones, the time it was set minus the time the page captured the audio of that
frame's time (the page's own ``headmotionAvatar.shown[].latencyMs``) — median and p95 over the
frames after the first five.  The browser, the server and this process share the cores; WebGL is
drawn by the CPU (SwiftShader).  Needs Playwright and Chromium (``HEADMOTION_CHROMIUM``, default
/usr/bin/chromium); without them the row says so.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import numpy as np

from serve_bench import Server

ROOT = Path(__file__).resolve().parents[1]
SPEECH = ROOT / "examples" / "speech" / "speech_female.wav"
CHROMIUM = os.environ.get("HEADMOTION_CHROMIUM", "/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
         "--autoplay-policy=no-user-gesture-required", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
         f"--use-file-for-fake-audio-capture={SPEECH}"]
P95_TARGET_MS = 150.0


def _wait(page, expr: str, timeout_s: float = 90.0) -> None:
    end = time.monotonic() + timeout_s
    while not page.evaluate(f"Boolean({expr})"):
        if time.monotonic() > end:
            raise TimeoutError(f"timed out waiting for {expr}")
        page.wait_for_timeout(50)


def page_latencies(url: str, frames: int) -> np.ndarray:
    """Latencies (ms) of the frames the avatar page put on its bones, until ``frames`` came."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        try:
            page = browser.new_page(viewport={"width": 700, "height": 760})
            page.goto(url + "/v1/avatar?input=mic&autostart=1")
            _wait(page, "document.body.dataset.ready")
            _wait(page, f"window.headmotionAvatar.frames >= {frames} || window.headmotionAvatar.error")
            shown = page.evaluate("headmotionAvatar.shown.map((s) => s.latencyMs)")
            error = page.evaluate("headmotionAvatar.error")
        finally:
            browser.close()
    if error:
        raise RuntimeError(f"the avatar page failed: {error}")
    lat = np.array([x for x in shown[5:] if x is not None], dtype=float)
    return lat[np.isfinite(lat)]


def bench_avatar(res, Row, quick: bool) -> None:
    group = "10 serve"
    label = "avatar page (/v1/avatar, Chromium, fake microphone): latency from the captured audio to the head bone"
    try:
        import playwright  # noqa: F401
    except ImportError:
        res.add(Row(group, label, None, "ms", "p95 <= 150 ms", None, "not measured: playwright is not installed"))
        return
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        res.add(Row(group, label, None, "ms", "p95 <= 150 ms", None, f"not measured: no Chromium at {CHROMIUM}"))
        return
    runs = []
    srv = Server()
    try:
        for _ in range(1 if quick else 3):
            load = os.getloadavg()[0]
            lat = page_latencies(srv.url, 100 if quick else 200)
            runs.append((np.median(lat), np.percentile(lat, 95), len(lat), load))
    finally:
        srv.stop()
    p95 = float(np.median([r[1] for r in runs]))
    res.add(Row(group, f"{label}: p95", p95, "ms", "p95 <= 150 ms", p95 <= P95_TARGET_MS,
                "runs (median / p95 ms, frames, load average): "
                + "; ".join(f"{m:.0f} / {q:.0f}, {n}, {ld:.1f}" for m, q, n, ld in runs)
                + "; shipped stream model, 25 fps, 20 ms chunks; browser, server and benchmark on the same cores"))
