"""The TalkingHead page of ``headmotion serve`` (``/v1/talkinghead``): its files are the package's
(TalkingHead and three.js bundled, its licence kept), and in headless Chromium on a real server the
bundled TalkingHead, with the project's avatar, speaks, streams and listens while ``driveTalkingHead``
of @headmotion/client turns its neck and head: every frame put on the head bone equals, within 0.5°,
the library's ``synthesize(model="stream")`` on the audio the page sent (TalkingHead's voice on its
speech channel, the fake microphone on its hear channel) at the same frame; while TalkingHead speaks,
the bone takes each frame at most 150 ms (p95) after the audio context played the frame's audio; its
own head movement is off while the driver runs and back after.  Browser tests skip with a reason
without Playwright or Chromium."""

from __future__ import annotations

import base64

import numpy as np
import pytest
from conftest import CHROMIUM
from serve_helpers import ROOT, registry
from test_avatar_browser import FLAGS, _wait

SPEECH = ROOT / "examples" / "speech" / "speech_female.wav"
LATENCY_P95_MS = 150.0
STATE = ("async () => ({shown: headmotionTalkingHead.shown, ready: headmotionTalkingHead.ready, "
         "error: headmotionTalkingHead.error, status: headmotionTalkingHead.status, audio: await headmotionTalkingHead.sentAudio(), "
         "now: headmotionTalkingHead.headRotation(), delay: headmotionTalkingHead.audioDelayS(), "
         "streams: headmotionTalkingHead.driver.streams, body: window.__body, done: window.__done, "
         "fixed: ['headRotateX', 'headRotateY', 'headRotateZ'].map((k) => headmotionTalkingHead.head.getFixedValue(k)), "
         "draco: headmotionTalkingHead.head.dracoEnabled})")
#: while the page speaks: the spine's and the hips' pose every 250 ms (TalkingHead's body, left to it)
SAMPLE_BODY = ("() => { window.__body = []; const h = headmotionTalkingHead.head; setInterval(() => { "
               "const s = h.armature.getObjectByName('Spine1'), p = h.armature.getObjectByName('Hips'); "
               "window.__body.push([...s.quaternion.toArray(), ...s.scale.toArray(), ...p.quaternion.toArray()]); }, 250); }")


def test_talkinghead_page_and_its_files_are_served():
    from serve_helpers import client

    c = client()
    page = c.get("/v1/talkinghead")
    assert page.status_code == 200 and "text/html" in page.headers["content-type"]
    assert "/v1/talkinghead/static/talkinghead-page.js" in page.text
    assert "'unsafe-inline'" not in page.headers["content-security-policy"]
    for path in ("static/talkinghead-page.js", "static/talkinghead.css", "static/talkinghead.glb",
                 "static/vendor/talkinghead.js", "static/vendor/playback-worklet.js", "static/vendor/lipsync-en.mjs",
                 "client/talkinghead.js", "client/clock-worklet.js", "client/index.js"):
        r = c.get(f"/v1/talkinghead/{path}")
        assert r.status_code == 200, path
        if path.endswith((".js", ".mjs")):
            assert "javascript" in r.headers["content-type"], path  # module scripts and worklets need it
    vendor = c.get("/v1/talkinghead/static/vendor/talkinghead.js").text
    assert vendor.startswith("/*! TalkingHead (@met4citizen/talkinghead") and "MIT License" in vendor[:2000]
    assert "Mika Suominen" in vendor[:2000] and "class" in vendor
    for text in (vendor, c.get("/v1/talkinghead/static/talkinghead-page.js").text,
                 c.get("/v1/talkinghead/client/talkinghead.js").text):
        for cdn in ("unpkg.com", "jsdelivr", "cdnjs", "esm.sh"):
            assert cdn not in text
    assert c.get("/v1/talkinghead/static/talkinghead.glb").content[:4] == b"glTF"


def _run(playwright, query: str, begin=None, frames: int = 0) -> dict:
    """Open ``/v1/talkinghead?QUERY`` on ``headmotion serve`` with the fake microphone playing SPEECH;
    run ``begin`` (a function and its argument) once the page is ready and wait for it to set
    ``window.__done`` (or for ``frames`` frames); the page's state then, with the audio it sent."""
    from headmotion.serve.app import create_app
    from headmotion.serve.config import ServeConfig
    from headmotion.web.server import running_app

    app = create_app(ServeConfig(), registry=registry())
    with running_app(app, ws="websockets-sansio") as url, playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=[*FLAGS, f"--use-file-for-fake-audio-capture={SPEECH}"])
        try:
            pg = b.new_page(viewport={"width": 700, "height": 760})
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.on("console", lambda m: m.type == "error" and errors.append(m.text))
            pg.goto(url + "v1/talkinghead?" + query)
            _wait(pg, "document.body.dataset.ready", 90)
            assert pg.evaluate("document.body.dataset.ready") == "1", pg.inner_text("#error")
            pg.evaluate(SAMPLE_BODY)
            if begin is not None:
                pg.evaluate("window.__done = false")
                pg.evaluate(*begin)
                _wait(pg, "window.__done", 90)
            else:
                _wait(pg, f"window.headmotionTalkingHead.frames >= {frames} || window.headmotionTalkingHead.error", 90)
            pg.wait_for_timeout(300)
            st = pg.evaluate(STATE)
            pg.evaluate("headmotionTalkingHead.stop()")
            st["after_stop"] = pg.evaluate("({fixed: ['headRotateX', 'headRotateY', 'headRotateZ'].map((k) => "
                                           "headmotionTalkingHead.head.getFixedValue(k)), "
                                           "update: headmotionTalkingHead.head.opt.update})")
        finally:
            b.close()
    st["errors"] = errors
    a = st["audio"]
    st["rate"] = int(a["sampleRate"])
    st["speech"] = np.frombuffer(base64.b64decode(a["speech"]), "<i2").astype(np.float32) / 32768.0
    st["hear"] = None if a["hear"] is None else np.frombuffer(base64.b64decode(a["hear"]), "<i2").astype(np.float32) / 32768.0
    return st


def _follows(st, ref) -> tuple[np.ndarray, np.ndarray]:
    """The frames the last stream put on the bones, in order, each within 0.5° of ``ref`` at the same
    frame, and the head moved; returns their frames and latencies (ms), and prints the largest
    difference."""
    from headmotion.rotations import rotvec_to_pitch_yaw_roll

    assert not st["errors"], st["errors"]
    assert st["error"] is None and st["status"].startswith("driving"), (st["error"], st["status"])
    shown = [s for s in st["shown"] if s["stream"] == st["audio"]["stream"]]
    idx = np.array([s["frame"] for s in shown])
    assert len(idx) > 40 and list(idx) == sorted(set(idx)), len(idx)  # in order, none twice
    assert idx.max() < len(ref)
    got = np.array([s["rotation"] for s in shown])
    err = np.abs(got - rotvec_to_pitch_yaw_roll(ref.rotvec, degrees=True)[idx]).max(axis=1)
    assert err.max() <= 0.5, (err.max(), int(idx[err.argmax()]))
    print(f"largest difference from synthesize: {err.max():.2e} deg over {len(idx)} frames")
    assert np.ptp(got, axis=0).max() > 1.0  # the head moved (degrees)
    np.testing.assert_allclose(st["now"], got[-1], atol=1e-9)  # the bones hold the newest frame
    return idx, np.array([np.nan if s["latencyMs"] is None else s["latencyMs"] for s in shown])


def _voiced(st, idx, fps) -> np.ndarray:
    """Which of the frames ``idx`` lie where TalkingHead's voice is on the speech channel."""
    loud = np.flatnonzero(np.abs(st["speech"]) > 0.02)
    t = idx / fps
    return (t >= loud[0] / st["rate"]) & (t <= loud[-1] / st["rate"])


def _driver_off_while_driving_and_back_after(st) -> None:
    assert st["fixed"] == [0, 0, 0]  # TalkingHead's random head turns held at 0
    body = np.array(st["body"])
    assert len(body) > 10 and np.ptp(body, axis=0).max() > 1e-4  # its body still breathes and sways
    assert st["after_stop"] == {"fixed": [None, None, None], "update": None}
    assert st["draco"] is False  # (its Draco decoder would come from a CDN)


def _speech_b64() -> str:
    return base64.b64encode(SPEECH.read_bytes()).decode()


@pytest.mark.browser
@pytest.mark.timeout(300)
def test_speak_audio_moves_the_head_with_the_voice(playwright):
    """``head.speakAudio`` of a decoded file: the whole utterance goes to the stream when TalkingHead
    starts playing it, so its frames are read ahead of the voice."""
    import headmotion
    from headmotion.types import Audio

    speak = ("(b64) => { const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0)); "
             "headmotionTalkingHead.speak(bytes.buffer).then(() => { window.__done = true; }, "
             "(e) => { window.__done = 'failed: ' + e; }); }")
    st = _run(playwright, "record=1", begin=(speak, _speech_b64()))
    assert st["done"] is True, st["done"]
    (ref,) = headmotion.synthesize(Audio(st["speech"], st["rate"]), model="stream")
    idx, lat = _follows(st, ref)
    voiced = _voiced(st, idx, ref.fps)
    assert voiced.sum() > 40 and np.all(np.isfinite(lat[voiced]))
    p95 = np.percentile(lat[voiced], 95)
    assert p95 <= LATENCY_P95_MS, p95
    _driver_off_while_driving_and_back_after(st)
    print(f"speakAudio: {len(idx)} frames on the bones ({voiced.sum()} in the voice); latency from the audio "
          f"played to the bone: median {np.median(lat[voiced]):.0f} ms, p95 {p95:.0f} ms")


@pytest.mark.browser
@pytest.mark.timeout(300)
def test_streamed_audio_is_held_by_the_lookahead_and_the_head_follows(playwright):
    """``streamStart({sampleRate: 16000})`` (a new AudioContext: the driver opens a new stream on it) and
    ``streamAudio`` chunks of 40 ms, made at twice the pace of real time as a TTS engine makes them,
    with ``?lookahead_ms=200``: each chunk is sent at once and reaches TalkingHead 200 ms later (the
    whole frames read ahead), and the bones take ``synthesize(lookahead_ms=200)``'s frames of the
    audio sent."""
    import headmotion
    from headmotion.types import Audio

    run = ("(b64) => { const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0)); "
           "headmotionTalkingHead.streamFile(bytes.buffer, {sampleRate: 16000, chunkMs: 40, speed: 2}).then(() => "
           "{ window.__done = true; }, (e) => { window.__done = 'failed: ' + e; }); }")
    st = _run(playwright, "record=1&lookahead_ms=200", begin=(run, _speech_b64()))
    assert st["done"] is True, st["done"]
    assert st["rate"] == 16000 and st["streams"] >= 2 and st["delay"] == pytest.approx(0.2, abs=1e-9)
    assert st["ready"]["lookahead_ms"] == 200
    (ref,) = headmotion.synthesize(Audio(st["speech"], st["rate"]), model="stream", lookahead_ms=200)
    idx, lat = _follows(st, ref)
    voiced = _voiced(st, idx, ref.fps)
    p95 = np.percentile(lat[voiced], 95)
    assert voiced.sum() > 40 and p95 <= LATENCY_P95_MS, (voiced.sum(), p95)
    print(f"streamAudio: {len(idx)} frames on the bones ({voiced.sum()} in the voice); latency from the audio "
          f"played to the bone: median {np.median(lat[voiced]):.0f} ms, p95 {p95:.0f} ms")


@pytest.mark.browser
@pytest.mark.timeout(300)
def test_the_head_listens_to_the_microphone(playwright):
    """``?input=mic&autostart=1``: the fake microphone is heard while TalkingHead is silent; the bones
    take ``synthesize(SILENCE, hear=MICROPHONE)``'s frames."""
    import headmotion
    from headmotion.types import Audio

    st = _run(playwright, "input=mic&autostart=1&record=1", frames=200)
    assert st["status"].startswith("driving, listening to the microphone")
    assert st["hear"] is not None and np.abs(st["hear"]).max() > 0.05 and not st["speech"].any()
    assert len(st["hear"]) == len(st["speech"])  # both channels from the start, on one clock
    (ref,) = headmotion.synthesize(Audio(st["speech"], st["rate"]), model="stream", hear=Audio(st["hear"], st["rate"]))
    idx, lat = _follows(st, ref)
    _driver_off_while_driving_and_back_after(st)
    print(f"listening: {len(idx)} frames on the bones; latency from the microphone's audio to the bone: "
          f"median {np.nanmedian(lat):.0f} ms, p95 {np.nanpercentile(lat, 95):.0f} ms")


@pytest.mark.browser
@pytest.mark.timeout(300)
def test_a_cut_voice_settles_the_head_and_a_new_stream_takes_over(playwright):
    """``head.stopSpeaking()`` 4 s into the file: the speech already sent will not play, so the stream
    is interrupted at the frame shown, its settling eases the head to rest at its own pace (not tied
    to any audio), and a new stream carries on from there.  The driver runs its streams on the page's
    thread here, as it does where it cannot make a worker (imported from another origin)."""
    cut = ("async (b64) => { const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0)); "
           "window.Worker = function () { throw new DOMException('no worker', 'SecurityError'); }; "
           "const th = headmotionTalkingHead; await th.start(false); "
           "th.speak(bytes.buffer); await new Promise((r) => setTimeout(r, 4000)); "
           "window.__cut = performance.now(); th.head.stopSpeaking(); "
           "await new Promise((r) => setTimeout(r, 2500)); window.__done = true; }")
    st = _run(playwright, "record=1", begin=(cut, _speech_b64()))
    assert not st["errors"] and st["error"] is None, (st["errors"], st["error"])
    assert st["streams"] == 2 and st["audio"]["stream"] == 2
    first = [s for s in st["shown"] if s["stream"] == 1]
    settling = [s for s in first if s["latencyMs"] is None]
    spoken = [s for s in first if s["latencyMs"] is not None]
    assert len(spoken) > 20 and settling  # (a frame or more of the settling: the page draws at its pace)
    assert settling[0]["frame"] > spoken[-1]["frame"] and settling[0]["at"] > spoken[-1]["at"]
    assert np.abs(settling[-1]["rotation"]).max() < 1.0  # eased to rest (degrees)
    after = [s for s in st["shown"] if s["stream"] == 2]
    assert len(after) > 5 and after[0]["at"] >= settling[-1]["at"]
