"""A voice agent's lookahead (``lookahead_ms``) without any agent framework: the agent's live core
reads the TTS audio ahead and its frames are ``synthesize``'s with the same lookahead; the audio
hold (:mod:`headmotion.live.hold`) that the Pipecat and LiveKit integrations run passes the agent's
audio on only once the lookahead's audio has come, in order with everything else; and, with a TTS
that makes its audio in real time, the frames then go out when their audio plays — as without a
lookahead — where audio passed on at once would lead the head by the lookahead."""

from __future__ import annotations

import asyncio
from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.live import AGENT_LOOKAHEAD_MS
from headmotion.live.core import FrameBatch, HeadMotionCore
from headmotion.live.hold import AudioHold, agent_core
from headmotion.live.pacing import Pacer
from headmotion.synthesis import Controls, load_model, synthesize
from headmotion.types import Audio

ROOT = Path(__file__).resolve().parents[1]
FPS = 25.0
CHUNK = 320  # 20 ms at 16 kHz, as a TTS sends it


@pytest.fixture(scope="module")
def speech():
    import soundfile as sf

    x, sr = sf.read(ROOT / "examples" / "speech" / "short.wav", dtype="float32")
    assert sr == 16000
    return x


@pytest.fixture(scope="module")
def model():
    return load_model("stream")


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def test_the_agents_default_lookahead_and_an_explicit_one(model):
    """None: :data:`AGENT_LOOKAHEAD_MS` for the live ``stream`` model, the value of ``controls``
    when it sets one, 0 for a model that is not live; a value is checked as everywhere."""
    assert agent_core(model, settle_s=0.5).controls.lookahead_ms == AGENT_LOOKAHEAD_MS
    assert agent_core(model, settle_s=0.5, lookahead_ms=200).controls.lookahead_ms == 200.0
    assert agent_core(model, settle_s=0.5, controls=Controls(lookahead_ms=120)).controls.lookahead_ms == 120.0
    assert agent_core(model, settle_s=0.5, gain=1.5, lookahead_ms=80).controls.gain == (1.5, 1.5, 1.5)
    assert agent_core("default", settle_s=0.5).controls.lookahead_ms == 0.0
    with pytest.raises(ParameterError, match="not live"):
        agent_core("default", settle_s=0.5, lookahead_ms=200)
    with pytest.raises(ParameterError, match="lookahead_ms"):
        agent_core(model, settle_s=0.5, lookahead_ms=2000)
    with pytest.raises(ParameterError, match="not both"):
        agent_core(model, settle_s=0.5, controls=Controls(), gain=2)


@pytest.mark.parametrize("lookahead_ms", [0, 120, 400])
def test_the_core_reads_ahead_and_gives_synthesizes_frames(model, speech, lookahead_ms):
    """The core's frames of an utterance (pushed in 20 ms chunks, ended) are ``synthesize``'s with
    the same lookahead; its latency grows by the whole frames read ahead; a listening turn, whose
    audio comes live, reads nothing ahead."""
    core = HeadMotionCore(model, settle_s=0.0, lookahead_ms=lookahead_ms)
    base = HeadMotionCore(model).latency_ms
    assert core.latency_ms == pytest.approx(base + 40.0 * (lookahead_ms * 25 // 1000))
    rows = [core.push(speech[i:i + CHUNK], 16000).rotvec for i in range(0, len(speech), CHUNK)]
    rows += [b.rotvec for b in core.end() if isinstance(b, FrameBatch)]
    want = synthesize(Audio(speech, 16000), model, lookahead_ms=lookahead_ms)[0].rotvec
    np.testing.assert_allclose(np.vstack(rows), want, rtol=0, atol=1e-6)
    core.hear(speech[:CHUNK], 16000)
    assert core._listen.latency_ms == pytest.approx(base)


def test_the_hold_lets_audio_go_once_the_lookahead_has_come_in_order(model, speech):
    """Held by 0.1 s: a 20 ms chunk goes on once 0.1 s more audio has come; its utterance's start
    mark goes right before its first audio, anything else behind the audio held before it; the
    end lets everything go; an interruption drops the audio held (and the mark), not the rest."""
    pacer = Pacer(HeadMotionCore(model, lookahead_ms=100), clock=Clock())
    hold = AudioHold(pacer, 0.1, on_start=lambda n: f"start {n}")
    assert hold.other("before") == [("before", 0, 0)]  # nothing held: on at once
    out = []
    for k in range(8):
        out += hold.audio(f"a{k}", speech[k * CHUNK:(k + 1) * CHUNK], 16000)
        if k == 2:
            out += hold.other("text")
    assert [e[0] for e in out] == ["start 1", "a0", "a1", "a2", "text"]  # a2 goes once a7 has come
    assert [e[1:] for e in out] == [(0, 0), (CHUNK, 16000), (CHUNK, 16000), (CHUNK, 16000), (0, 0)]
    assert [e[0] for e in hold.release()] == ["a3", "a4", "a5", "a6", "a7"] and hold.held == 0
    pacer.end()
    first = [e[0] for e in hold.audio("b0", speech[:CHUNK], 16000)]
    assert first == [] and hold.other("text") == []
    assert [e[0] for e in hold.drop()] == ["text"] and hold.held == 0  # "start 2" and b0 never play
    nothing = AudioHold(Pacer(HeadMotionCore(model)), 0.0, on_start=lambda n: f"start {n}")
    assert [e[0] for e in nothing.audio("c0", speech[:CHUNK], 16000)] == ["start 1", "c0"]


def _real_time_tts(model, speech, lookahead_ms: float, held: bool):
    """A TTS making its audio in real time (20 ms chunks, each when made) through the hold (by the
    lookahead, or by nothing) to an output that plays what it is given from then on.  Returns, per
    frame of speech, when it went out minus when its audio played (seconds), and the frames."""
    clock = Clock()
    pacer = Pacer(agent_core(model, settle_s=0.5, lookahead_ms=lookahead_ms), clock=clock)
    hold = AudioHold(pacer, lookahead_ms / 1000.0 if held else 0.0)
    handed, sent, rows, end = {}, {}, {}, [0.0]

    async def output(item):  # plays what it is given from now on, after what it was given before
        handed[item] = max(clock.t, end[0])
        end[0] = handed[item] + CHUNK / 16000

    def step(entries):
        asyncio.run(hold.pass_on(entries, output))
        for m in pacer.due():
            if m["type"] == "frames" and not m.get("settling"):
                for f in m["frames"]:
                    sent[f["frame"]], rows[f["frame"]] = clock.t, f["rotvec"]

    for k, i in enumerate(range(0, len(speech), CHUNK)):
        clock.t = 100.0 + (k + 1) * CHUNK / 16000
        step(hold.audio(k, speech[i:i + CHUNK], 16000))
    clock.t += 0.001
    step(hold.release())
    pacer.end()
    while pacer.pending:
        clock.t += 0.005
        step([])
    lag = [sent[i] - (handed[i * 640 // CHUNK] + (i * 640 % CHUNK) / 16000) for i in sorted(sent)]
    return np.array(lag), np.array([rows[i] for i in sorted(rows)])


def test_with_a_real_time_tts_the_held_audio_plays_with_its_frames(model, speech):
    """Lookahead 200 ms and a TTS as fast as real time: with the audio held by 200 ms every frame
    goes out when its audio plays, as late as without a lookahead (the features' 39 ms at most);
    audio passed on at once plays 200 ms before its frames.  The frames are ``synthesize``'s."""
    lag0, _ = _real_time_tts(model, speech, 0.0, held=True)
    lag, rows = _real_time_tts(model, speech, 200.0, held=True)
    early, _ = _real_time_tts(model, speech, 200.0, held=False)
    assert len(lag) == len(lag0) == len(early) == len(rows) == 69
    assert lag0.min() >= -1e-9 and lag0.max() <= 0.045
    assert lag.min() >= -1e-9 and lag.max() <= lag0.max() + 1e-6  # in step with the voice, as without
    assert np.median(early) >= 0.2 - 1e-6  # the voice leads the head by the lookahead (but at its end)
    want = synthesize(Audio(speech, 16000), model, lookahead_ms=200)[0].rotvec
    np.testing.assert_allclose(rows, want, rtol=0, atol=1e-6)
