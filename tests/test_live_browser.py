"""``headmotion view --live`` in headless chromium: a fake microphone plays a
real speech file; the page streams it to the server over the WebSocket, frames come back, the
head moves while the file plays, and the page shows the latency.

Skips with a reason without Playwright, chromium, or ../shared/data.
"""

from __future__ import annotations


import numpy as np
import pytest
from conftest import CHROMIUM, OLD_DNN_MODEL

pytestmark = [pytest.mark.browser, pytest.mark.shared, pytest.mark.timeout(180)]

#: a model that streams with lookahead at 100 fps (the former shipped default, mfcc-dnn)
MODEL = OLD_DNN_MODEL


@pytest.fixture(scope="module")
def speech_wav(tmp_path_factory, shared_data):
    import soundfile as sf

    from headmotion.io import load_audio

    a = load_audio(shared_data / "speech" / "jfk.flac")
    path = tmp_path_factory.mktemp("live") / "speech.wav"
    x = a.samples[: 8 * a.sample_rate]
    sf.write(path, x, a.sample_rate, subtype="PCM_16")
    return path



def test_live_page_moves_head_with_fake_microphone(speech_wav, playwright):
    from headmotion.systems.base import load_model
    from headmotion.web.live import running_live_server

    model = load_model(MODEL)
    with running_live_server(model) as url, playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--no-sandbox", "--disable-gpu", "--headless", "--autoplay-policy=no-user-gesture-required",
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
            "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-audio-capture={speech_wav}"])
        try:
            pg = b.new_page(viewport={"width": 800, "height": 700})
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.goto(url)
            pg.wait_for_function("document.body.dataset.ready", timeout=60000)
            assert pg.evaluate("document.body.dataset.ready") == "1", pg.inner_text("#error")
            pg.click("#mic")
            # ~6 s of the file: the algorithmic latency of the current model is 700 ms
            pg.wait_for_function("window.headmotionLive.frames >= 400", timeout=60000)
            pg.wait_for_timeout(300)
            st = pg.evaluate("window.headmotionLive")
            shot = pg.screenshot(path=str(speech_wav.parent / "live.png"))
            assert shot
            assert not errors, errors
            assert st["error"] is None, st["error"]
            assert st["status"].startswith("streaming (mic")
            rv = np.array([f["rotvec"] for f in st["received"]])
            frames = [f["frame"] for f in st["received"]]
            assert frames == list(range(len(frames)))  # in order, none lost
            # the head moves: several degrees of range on at least one axis
            assert np.degrees(np.ptp(rv, axis=0)).max() > 2.0, np.degrees(np.ptp(rv, axis=0))
            # the drawn head is the newest frame, and the page shows the latency
            both = pg.evaluate("({drawn: window.headmotionViewers[0].getState().rotvec[0], "
                               "recent: window.headmotionLive.received.slice(-50).map((f) => f.rotvec)})")
            gap = np.abs(np.array(both["recent"]) - np.array(both["drawn"])[None]).max(axis=1)
            assert gap.min() < 1e-6  # the drawn head is one of the newest frames
            lat = np.array(st["latencies"])
            assert lat.size > 100 and np.all(np.isfinite(lat))
            assert 0 < np.median(lat) < 3000
            assert "latency median" in pg.inner_text("#stats")
        finally:
            b.close()


def test_live_page_with_a_chosen_audio_file(speech_wav, playwright):
    from headmotion.systems.base import load_model
    from headmotion.web.live import running_live_server

    with running_live_server(load_model(MODEL)) as url, playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--no-sandbox", "--disable-gpu", "--headless", "--autoplay-policy=no-user-gesture-required",
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        try:
            pg = b.new_page(viewport={"width": 800, "height": 700})
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.goto(url)
            pg.wait_for_function("document.body.dataset.ready", timeout=60000)
            pg.set_input_files("#file", str(speech_wav))
            # the 8 s file plays to its end; the flush at the end delivers the last frames
            pg.wait_for_function("window.headmotionLive.status === 'file finished'", timeout=60000)
            pg.wait_for_function("window.headmotionLive.frames >= 790", timeout=20000)
            st = pg.evaluate("window.headmotionLive")
            assert not errors and st["error"] is None, (errors, st["error"])
            assert st["status"] == "file finished"
            rv = np.array([f["rotvec"] for f in st["received"]])
            assert abs(len(rv) - 800) <= 2      # every frame of the 8 s, in order
            assert [f["frame"] for f in st["received"]] == list(range(len(rv)))
            assert np.degrees(np.ptp(rv, axis=0)).max() > 2.0
        finally:
            b.close()
