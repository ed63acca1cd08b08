"""A real Pipecat pipeline driving the avatar page in a real browser.

The pipeline — ``transport.input()``, a local speech source in place of the TTS (it plays
examples/speech/*.wav as ``TTSAudioRawFrame``s, faster than real time as a TTS does),
``HeadMotionProcessor(rtvi=True)``, ``transport.output()`` — runs on Pipecat's FastAPI WebSocket
transport (``ProtobufFrameSerializer``) on localhost, in the app that also serves ``/v1/avatar``
(:func:`headmotion.serve.avatar.mount_avatar`) and Pipecat's own browser client from npm
(``@pipecat-ai/client-js`` with ``@pipecat-ai/websocket-transport``, bundled here with esbuild from
tests/pipecat_client/).  Headless Chromium opens the avatar page with a fake microphone playing
real speech; the client plays the bot's audio and gives each frame message to the avatar page's
``follow`` with the audio its player had been given, and the page puts the frame on the bones when
the player has played the frame's audio (``played``, counted in the audio graph).

From what the page records — the bot audio it was given, every block its player output (on the
audio clock) and when each frame reached the bones — the test places every played sample exactly
(each player node's output found sample for sample in the audio given) and checks that the head
moves in time with the audio the page plays (p95 offset ≤ 100 ms over the frames whose audio was
played), settles to rest when the speech is interrupted, and listens (a listening turn, its
attentive posture) when the fake microphone speaks while the bot is silent.

Runs in the Pipecat environment of scripts/test-integrations.sh (``pipecat-ai[websocket]``,
``playwright``); skips with a reason without them, without Chromium or without npm."""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pipecat", reason="pipecat-ai is not installed (scripts/test-integrations.sh)")
pytest.importorskip("pipecat.transports.websocket.fastapi", reason="needs pipecat-ai[websocket]")
pytest.importorskip("playwright.sync_api", reason="needs the playwright package")

ROOT = Path(__file__).resolve().parents[1]
CLIENT = ROOT / "tests" / "pipecat_client"
SPEECH = ROOT / "examples" / "speech"
CHROMIUM = os.environ.get("HEADMOTION_CHROMIUM", "/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--autoplay-policy=no-user-gesture-required", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream"]
RATE = 24000  # the TTS's and the output's rate (the client's WavMediaManager plays at 24 kHz)
FPS = 25.0
UTTER_GAP_S = 1.0
INTERRUPT_AFTER_S = 2.5
LISTEN_S = 6.0
pytestmark = pytest.mark.browser


def _speech(name: str, seconds: float | None = None) -> np.ndarray:
    """A speech file as int16 at RATE (soxr, offline)."""
    import soundfile as sf
    import soxr

    x, sr = sf.read(SPEECH / name, dtype="float32")
    if seconds is not None:
        x = x[:int(seconds * sr)]
    y = soxr.resample(x, sr, RATE, quality="HQ")
    return np.clip(np.round(y * 32767), -32768, 32767).astype(np.int16)


@pytest.fixture(scope="module")
def bundle(tmp_path_factory) -> Path:
    """The client bundled from npm (``npm ci`` once, then esbuild)."""
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"chromium not found at {CHROMIUM}")
    npm = shutil.which("npm")
    if npm is None:
        pytest.skip("npm not found: the test bundles Pipecat's browser client from npm")
    if not (CLIENT / "node_modules" / ".bin" / "esbuild").exists():
        r = subprocess.run([npm, "ci", "--no-audit", "--no-fund"], cwd=CLIENT, capture_output=True, text=True,
                           timeout=600)
        assert r.returncode == 0, f"npm ci failed in {CLIENT}:\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}"
    out = tmp_path_factory.mktemp("pipecat_client")
    r = subprocess.run([str(CLIENT / "node_modules" / ".bin" / "esbuild"), "client.js", "--bundle", "--format=esm",
                        "--target=es2020", f"--outfile={out / 'client.js'}"], cwd=CLIENT, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return out


def _app(bundle: Path, script: list):
    """The server: /v1/avatar, the client bundle under /pipecat/, and the pipeline on WS /ws."""
    from fastapi import FastAPI
    from fastapi.staticfiles import StaticFiles
    from pipecat.pipeline.pipeline import Pipeline
    from pipecat.pipeline.worker import PipelineParams, PipelineWorker
    from pipecat.serializers.protobuf import ProtobufFrameSerializer
    from pipecat.transports.websocket.fastapi import FastAPIWebsocketParams, FastAPIWebsocketTransport
    from pipecat.workers.runner import WorkerRunner
    from starlette.routing import WebSocketRoute

    from headmotion.integrations.pipecat import HeadMotionProcessor
    from headmotion.serve.avatar import mount_avatar

    app = FastAPI()
    mount_avatar(app)
    app.mount("/pipecat", StaticFiles(directory=bundle), name="pipecat")

    async def ws(websocket):  # a plain Starlette route (no annotation for FastAPI to resolve)
        await websocket.accept()
        transport = FastAPIWebsocketTransport(websocket, FastAPIWebsocketParams(
            audio_in_enabled=True, audio_out_enabled=True, audio_out_sample_rate=RATE,
            serializer=ProtobufFrameSerializer()))
        pipeline = Pipeline([transport.input(), _local_speech(script), HeadMotionProcessor(rtvi=True),
                             transport.output()])
        worker = PipelineWorker(pipeline, params=PipelineParams(audio_out_sample_rate=RATE))

        @transport.event_handler("on_client_disconnected")
        async def _gone(_transport, _ws):
            await worker.cancel()

        runner = WorkerRunner(handle_sigint=False)
        await runner.add_workers(worker)
        await runner.run()

    app.router.routes.append(WebSocketRoute("/ws", ws))
    return app


def _local_speech(script: list):
    """The TTS's place in the pipeline: once the client's microphone audio flows, it plays the
    script — ``("say", pcm)`` (TTSStarted, 20 ms TTSAudioRawFrames at 4× real time, TTSStopped),
    ``("wait", s)``, ``("interrupt", s)`` (interrupts the pipeline s seconds after the last say
    started), ``("mark", dict)`` (a message to the page) — and passes every frame on."""
    from pipecat.frames.frames import InputAudioRawFrame, TTSAudioRawFrame, TTSStartedFrame, TTSStoppedFrame
    from pipecat.processors.frame_processor import FrameDirection, FrameProcessor
    from pipecat.processors.frameworks.rtvi import RTVIServerMessageFrame

    class LocalSpeech(FrameProcessor):
        def __init__(self):
            super().__init__(name="local-speech")
            self._task = None

        async def process_frame(self, frame, direction):
            await super().process_frame(frame, direction)
            if isinstance(frame, InputAudioRawFrame) and self._task is None:
                self._task = self.create_task(self._play())
            await self.push_frame(frame, direction)

        async def _play(self):
            said = time.monotonic()
            for step, arg in script:
                if step == "say":
                    said = time.monotonic()
                    await self.push_frame(TTSStartedFrame())
                    n = RATE // 50
                    for i in range(0, len(arg), n):
                        await self.push_frame(TTSAudioRawFrame(audio=arg[i:i + n].tobytes(), sample_rate=RATE,
                                                               num_channels=1))
                        await asyncio.sleep(0.005)
                    await self.push_frame(TTSStoppedFrame())
                    # after the audio went by: the page gets it while this utterance's frames go out
                    await self.push_frame(RTVIServerMessageFrame(data={"type": "test-said", "samples": len(arg)}))
                elif step == "wait":
                    await asyncio.sleep(arg)
                elif step == "interrupt":
                    await asyncio.sleep(max(0.0, said + arg - time.monotonic()))
                    await self.push_frame(RTVIServerMessageFrame(data={"type": "test-interrupt"}))
                    await self.broadcast_interruption()
                elif step == "mark":
                    await self.push_frame(RTVIServerMessageFrame(data=arg), FrameDirection.DOWNSTREAM)

    return LocalSpeech()


def _clock(rec) -> float:
    """The wall time (ms, performance.now) at which the player's audio-clock frame 0 was heard: the
    page's readings of both clocks, less the output latency (their median)."""
    return float(np.median([c["wall"] - 1000.0 * (c["ctx"] - c["out"]) for c in rec["clock"]]))


def _heard(rec) -> tuple[np.ndarray, np.ndarray]:
    """The bot audio the page was given (int16, in order) and where each of its samples was played:
    the audio-clock frame, or -1 for the samples the player dropped (the partial block a player node
    leaves when it runs dry).  Each player node's output, as the page recorded it block by block, is
    found sample for sample in the audio given (the player turns int16 into float exactly), after
    where the node before it ended; blocks of silence a node plays before its first audio are
    skipped."""
    given = np.concatenate([np.asarray(r["x"], np.int16) for r in rec["received"]])
    where = np.full(len(given), -1, np.int64)
    nodes: dict[int, list] = {}
    for p in rec["played"]:
        nodes.setdefault(p["node"], []).append(p)
    q = 0
    for node in sorted(nodes):
        blocks = sorted(nodes[node], key=lambda p: p["f"])
        x = np.round(np.concatenate([p["x"] for p in blocks]) * 32768.0).astype(np.int64)
        f = np.concatenate([p["f"] + np.arange(len(p["x"])) for p in blocks])
        found = None
        for skip in range(0, min(len(x), 8 * 128), 128):
            n = min(len(x) - skip, 2048)
            for d in np.flatnonzero(given[q:q + min(RATE, len(given) - q - n + 1)] == x[skip]):
                if np.array_equal(x[skip:skip + n], given[q + d:q + d + n]):
                    found = (skip, d)
                    break
            if found:
                break
        if found is None and not x.any():
            continue  # a node that played only the silence before its first audio (the page stopped)
        assert found is not None, f"player node {node}: its output is not the audio given after sample {q}"
        skip, d = found[0], int(found[1])
        n = min(len(x) - skip, len(given) - q - d)
        assert np.array_equal(x[skip:skip + n], given[q + d:q + d + n]), f"player node {node} left the audio given"
        where[q + d:q + d + n] = f[skip:skip + n]
        q += d + n
    return given, where


def _heard_at(where: np.ndarray, r: int) -> int | None:
    """The audio-clock frame where sample ``r`` of the audio given was heard; None where the player
    dropped it (the audio written to a player node that had run dry) or never played it."""
    return int(where[r]) if 0 <= r < len(where) and where[r] >= 0 else None


def _start(given: np.ndarray, pcm: np.ndarray, after: int = 0) -> int:
    """Where ``pcm`` begins in the audio given (its first 2400 samples, exactly)."""
    head = pcm[:2400]
    for i in range(after, len(given) - len(head) + 1):
        if given[i] == head[0] and np.array_equal(given[i:i + len(head)], head):
            return i
    raise AssertionError("the page was not given the speech")


def _turns(messages: list[dict]) -> list[dict]:
    """The headmotion messages split at each ``end`` into turns: ``{"say": k}`` for the k-th
    utterance the speech source played (the turn its ``test-said`` mark arrives in: the source sends
    it once the utterance's audio has gone by, while its frames still go out with the audio),
    ``{"say": None}`` for a listening turn; ``frames``: [{at, shown, frame, first, rotvec, bones}, ...]
    per message (``at`` when it came, ``shown`` when its frame reached the bones, ``bones`` the pose
    read back then; messages never shown are left out).  The last turn may have no end yet."""
    turns, cur, says, pending = [], None, 0, None
    for m in messages:
        msg = m["msg"]
        if msg.get("type") == "test-said":
            if cur is not None:
                cur["say"] = says
            else:
                pending = says
            says += 1
        elif msg.get("type") == "frames":
            if cur is None:
                cur = {"say": pending, "frames": []}
                pending = None
            f, shown = msg["frames"][-1], m["shown"]
            if shown["shownAt"] is None:
                continue
            cur["frames"].append({"at": m["at"], "shown": shown["shownAt"], "frame": f["frame"],
                                  "first": msg["frames"][0]["frame"], "rotvec": f["rotvec"],
                                  "bones": shown["rotation"]})
        elif msg.get("type") == "end" and cur is not None:
            turns.append(cur)
            cur = None
    return turns if cur is None else [*turns, cur]


def test_pipecat_pipeline_drives_the_avatar_page(bundle, tmp_path):
    from playwright.sync_api import sync_playwright

    from headmotion.web.server import running_app

    first, second = _speech("short.wav"), _speech("speech_female.wav", 6.0)
    script = [("say", first), ("wait", len(first) / RATE + UTTER_GAP_S), ("say", second),
              ("interrupt", INTERRUPT_AFTER_S), ("wait", LISTEN_S), ("mark", {"type": "test-done"})]
    mic = SPEECH / "speech_male.wav"
    with running_app(_app(bundle, script), ws="websockets-sansio") as url, sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=[*FLAGS, f"--use-file-for-fake-audio-capture={mic}"])
        try:
            pg = b.new_page(viewport={"width": 600, "height": 640})
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.goto(url + "v1/avatar")
            pg.wait_for_function("document.body.dataset.ready", timeout=60000)
            assert pg.evaluate("document.body.dataset.ready") == "1", pg.inner_text("#error")
            pg.add_script_tag(url="/pipecat/client.js", type="module")
            pg.wait_for_function("window.pipecatRecord && (window.pipecatRecord.messages.some("
                                 "(m) => m.msg.type === 'test-done') || window.pipecatRecord.errors.length)",
                                 timeout=120000)
            pg.wait_for_timeout(500)
            rec = pg.evaluate("window.pipecatRecord")
            pg.screenshot(path=str(tmp_path / "avatar_pipecat.png"))
        finally:
            b.close()
    (tmp_path / "record.json").write_text(json.dumps(rec))
    assert not errors and not rec["errors"], (errors, rec["errors"])
    unshown = [m["msg"]["frames"][-1]["frame"] for m in rec["messages"]
               if m["msg"].get("type") == "frames" and m["shown"]["shownAt"] is None]
    assert not unshown, f"frames never put on the bones (their audio never played): {unshown}"

    given, where = _heard(rec)
    wall0 = _clock(rec)
    turns = _turns(rec["messages"])
    said = [t for t in turns if t["say"] is not None]
    listened = [t for t in turns if t["say"] is None]
    assert [t["say"] for t in said] == [0, 1], [t["say"] for t in turns]
    interrupt_at = next(m["at"] for m in rec["messages"] if m["msg"].get("type") == "test-interrupt")

    # 1. in time with the audio the page plays: each frame on the bones against the moment the page
    # played the audio at that frame's time (its place in the audio the page was given)
    offsets, after = [], 0
    for pcm, turn in ((first, said[0]), (second, said[1])):
        start = after = _start(given, pcm, after)
        for f in turn["frames"]:
            r = start + int(round(f["frame"] / FPS * RATE))
            heard = _heard_at(where, r) if r < min(len(given), start + len(pcm)) else None
            if heard is None or f["at"] >= interrupt_at:
                continue  # audio the player dropped or never played, or after the interruption
            offsets.append(f["shown"] - (wall0 + 1000.0 * heard / rec["rate"]))
    off = np.array(offsets)
    n = sum(len(t["frames"]) for t in said)
    dropped = int(np.sum(where[:len(given)] < 0))
    print(f"{len(off)} of {n} frames on the bones measured; offset from the audio the page played: median "
          f"{np.median(off):.0f} ms, "
          f"p95 |offset| {np.percentile(np.abs(off), 95):.0f} ms, max |offset| {np.abs(off).max():.0f} ms "
          f"(load average {os.getloadavg()[0]:.1f}); the player dropped {dropped / RATE * 1000:.0f} ms of the "
          f"{len(given) / RATE:.1f} s of audio it was given")
    assert len(off) > 60
    assert np.percentile(np.abs(off), 95) <= 100.0

    # 2. it settles when interrupted: to the rest pose, without a jump, within settle_s and a margin
    # of the end of the voice (the last of the bot's audio the page played: the page may still play
    # audio it had when the server cut the speech off)
    late = [f for f in said[1]["frames"] if f["at"] >= interrupt_at]
    assert late, "no frame after the interruption"
    assert np.abs(late[-1]["rotvec"]).max() < 1e-4 and np.abs(late[-1]["bones"]).max() < 0.05
    bones = np.array([f["bones"] for f in late])
    assert np.abs(np.diff(bones, axis=0)).max() < 2.0  # degrees between settling frames on the bones
    voice_end = wall0 + 1000.0 * (where.max() + 1) / rec["rate"]
    assert late[-1]["shown"] - voice_end < 1000.0 * (0.5 + 0.3)
    print(f"settled {late[-1]['shown'] - voice_end:.0f} ms after the voice ended "
          f"({late[-1]['shown'] - interrupt_at:.0f} ms after the interruption) in {len(late)} messages")

    # 3. it listens when the fake microphone speaks and the bot is silent: listening turns (numbered
    # from 0 as an utterance), the attentive posture held in the long one after the interruption
    listen = listened[-1]["frames"]
    assert listen[0]["at"] > interrupt_at and listen[0]["first"] == 0 and listen[-1]["frame"] + 1 >= 2 * FPS
    pose = np.array([f["bones"] for f in listen[len(listen) // 2:]])
    assert np.abs(pose.mean(axis=0)).max() > 1.0, pose.mean(axis=0)  # degrees
    print(f"{len(listened)} listening turns; the last: {listen[-1]['frame'] + 1} frames, mean pose "
          f"{np.round(pose.mean(axis=0), 2)} deg (pitch, yaw, roll)")


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-s"]))
