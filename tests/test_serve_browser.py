"""The browser example of ``headmotion serve`` (``/v1/example``) in headless Chromium with a fake
microphone playing a speech file: the page streams it to ``/v1/stream``, frames come back in order
and the bundled head moves.  Skips with a reason without Playwright or Chromium."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CHROMIUM
from serve_helpers import ROOT, registry

pytestmark = [pytest.mark.browser, pytest.mark.timeout(180)]


def _wait_js(page, expr: str, timeout: float = 60000) -> None:
    """Poll ``expr`` through ``page.evaluate`` (``wait_for_function`` evals a string in the page,
    which the server's CSP, without 'unsafe-eval', refuses)."""
    import time

    end = time.monotonic() + timeout / 1000
    while not page.evaluate(f"Boolean({expr})"):
        if time.monotonic() > end:
            raise TimeoutError(f"timed out waiting for {expr}")
        page.wait_for_timeout(50)


def test_example_page_streams_microphone_and_moves_head(playwright):
    from headmotion.serve.app import create_app
    from headmotion.serve.config import ServeConfig
    from headmotion.web.server import running_app

    wav = ROOT / "examples" / "speech" / "speech_female.wav"
    app = create_app(ServeConfig(), registry=registry())
    with running_app(app, ws="websockets-sansio") as url, playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--no-sandbox", "--disable-gpu", "--headless", "--autoplay-policy=no-user-gesture-required",
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
            "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-audio-capture={wav}"])
        try:
            pg = b.new_page(viewport={"width": 800, "height": 700})
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.on("console", lambda m: m.type == "error" and errors.append(m.text))
            pg.goto(url + "v1/example")
            _wait_js(pg, "document.body.dataset.ready")
            assert pg.evaluate("document.body.dataset.ready") == "1", pg.inner_text("#error")
            pg.click("#mic")
            _wait_js(pg, "window.headmotionExample.frames >= 300")
            st = pg.evaluate("window.headmotionExample")
            assert not errors, errors
            assert st["error"] is None and st["status"].startswith("streaming: stream (motion-match)")
            frames = [f[0] for f in st["received"]]
            assert frames == list(range(len(frames)))  # in order, none lost or repeated
            rv = np.array([f[1] for f in st["received"]])
            assert np.degrees(np.ptp(rv, axis=0)).max() > 1.0  # the head moves
            lat = np.array(st["latencies"][50:])
            assert np.median(lat) < 1000, np.median(lat)
        finally:
            b.close()
