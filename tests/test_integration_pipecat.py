"""The Pipecat integration in a real Pipecat pipeline (pipecat's own ``run_test``: a pipeline worker
and runner with a source and a sink), without network: real TTS audio frames of a speech file in,
the audio out unchanged and in order, the head motion out as transport messages whose frames are
the stream's own for the same audio, and the head settling on TTS stop and on an interruption.

Runs where ``pipecat-ai`` is installed (scripts/test-integrations.sh makes that environment);
elsewhere it is skipped.  Processors that pass the audio on at once are built with
``lookahead_ms=0``; the agents' default budget (``AGENT_LOOKAHEAD_MS``) holds it by as much
(tests/test_agent_lookahead.py, the lookahead tests here and the browser test, which runs the default)."""

from __future__ import annotations

import asyncio
import sys

import numpy as np
import pytest

pytest.importorskip("pipecat", reason="pipecat-ai is not installed (pip install \"headmotion[pipecat]\")")

from loguru import logger  # noqa: E402
from pipecat.frames.frames import (  # noqa: E402
    InterruptionFrame,
    OutputTransportMessageFrame,
    OutputTransportMessageUrgentFrame,
    TTSAudioRawFrame,
    TTSStartedFrame,
    TTSStoppedFrame,
)
from pipecat.observers.base_observer import BaseObserver  # noqa: E402
from pipecat.tests.utils import SleepFrame, run_test  # noqa: E402

from agent_helpers import FPS, TOL, check_decided_together, check_settling, reference, utterances  # noqa: E402
from agent_helpers import speech_pcm as _speech  # noqa: E402

from headmotion.integrations.pipecat import HeadMotionProcessor  # noqa: E402



@pytest.fixture(autouse=True, scope="module")
def _quiet_pipecat():
    logger.remove()
    logger.add(sys.stderr, level="WARNING")
    yield




def _tts_frames(pcm: np.ndarray, rate: int, chunk_s: float = 0.05) -> list:
    n = int(rate * chunk_s)
    return [TTSAudioRawFrame(audio=pcm[i:i + n].tobytes(), sample_rate=rate, num_channels=1)
            for i in range(0, len(pcm), n)]




def _messages(frames, kind) -> list[dict]:
    return [f.message for f in frames if type(f) is kind]






def _audio_out(down) -> list:
    return [f for f in down if isinstance(f, TTSAudioRawFrame)]


def _assert_audio_unchanged(sent: list, received: list) -> None:
    assert len(received) == len(sent)
    for a, b in zip(sent, received):
        assert b.audio == a.audio and b.sample_rate == a.sample_rate and b.num_channels == a.num_channels
        assert b.id == a.id  # the same frames, in the same order


@pytest.mark.parametrize("rate", [16000, 24000])
def test_utterance_frames_equal_the_stream_and_audio_passes_unchanged(rate):
    pcm = _speech(rate)
    audio = _tts_frames(pcm, rate)
    proc = HeadMotionProcessor(pace=False, lookahead_ms=0)
    down, _ = asyncio.run(run_test(proc, frames_to_send=[TTSStartedFrame(), *audio, TTSStoppedFrame()]))

    _assert_audio_unchanged(audio, _audio_out(down))
    assert isinstance(down[0], TTSStartedFrame) and isinstance(down[-1], TTSStoppedFrame)
    msgs = _messages(down, OutputTransportMessageFrame)
    assert msgs and _messages(down, OutputTransportMessageUrgentFrame) == []
    (utt,) = utterances(msgs, angles=True)
    ref = reference(pcm, rate)
    n = len(ref)
    assert n == pytest.approx(len(pcm) / rate * FPS, abs=2)  # 25 frames a second of speech
    assert utt["numbers"] == list(range(n + proc.core.settle_frames))
    np.testing.assert_allclose(utt["rotvec"][:n], ref, atol=TOL, rtol=0)
    check_settling(ref, utt["rotvec"][n:], proc.core.settle_frames)
    assert utt["end"] == {"type": "end", "frames": n + proc.core.settle_frames,
                          "audio_seconds": round(len(pcm) / rate, 4), "utterance": 1}
    # the utterance's audio is preceded by its audio-start message, in order with it
    first_audio = next(i for i, f in enumerate(down) if isinstance(f, TTSAudioRawFrame))
    assert down[first_audio - 1].message == {"type": "audio-start", "utterance": 1}
    assert msgs[0] == {"type": "audio-start", "utterance": 1}
    # each frames message follows the audio frame that completed its frames, before the next audio frame
    first_msg = next(i for i, f in enumerate(down) if isinstance(f, OutputTransportMessageFrame)
                     and f.message["type"] == "frames")
    assert isinstance(down[first_msg - 1], TTSAudioRawFrame)
    assert all(m["utterance"] == 1 for m in msgs)
    assert [m.get("settling", False) for m in msgs if m["type"] == "frames"][-1]


def test_interruption_settles_and_the_next_utterance_starts_fresh():
    pcm = _speech()
    audio = _tts_frames(pcm, 16000)
    k = 30  # 1.5 s of the 2.8 s, then the user cuts the agent off
    proc = HeadMotionProcessor(pace=False, lookahead_ms=0)
    frames = [TTSStartedFrame(), *audio[:k], SleepFrame(0.5), InterruptionFrame(), SleepFrame(0.2),
              TTSStartedFrame(), *audio, TTSStoppedFrame()]
    down, _ = asyncio.run(run_test(proc, frames_to_send=frames))

    _assert_audio_unchanged(audio[:k] + audio, _audio_out(down))
    first, second = utterances(_messages(down, OutputTransportMessageFrame), angles=True)
    cut = reference(pcm[:k * 800], 16000, flush=False)  # what the stream had made when cut off
    m = len(cut)
    assert first["numbers"] == list(range(m + proc.core.settle_frames))
    np.testing.assert_allclose(first["rotvec"][:m], cut, atol=TOL, rtol=0)
    check_settling(cut, first["rotvec"][m:], proc.core.settle_frames)
    assert first["end"]["frames"] == m + proc.core.settle_frames
    assert first["end"]["audio_seconds"] == pytest.approx(k * 0.05)
    # the interruption went on downstream before the settling
    i_int = next(i for i, f in enumerate(down) if isinstance(f, InterruptionFrame))
    i_settle = [i for i, f in enumerate(down) if isinstance(f, OutputTransportMessageFrame)
                and f.message["type"] == "frames" and f.message["first"] >= m]
    assert i_settle and min(i_settle) > i_int

    ref = reference(pcm, 16000)  # a fresh stream: the same frames as the first time it was heard
    assert second["numbers"][:len(ref)] == list(range(len(ref)))
    np.testing.assert_allclose(second["rotvec"][:len(ref)], ref, atol=TOL, rtol=0)
    np.testing.assert_allclose(second["rotvec"][-1], 0.0, atol=TOL)


class _Sent(BaseObserver):
    """When each frame left the processor (the pipeline clock's time of the push, in seconds)."""

    def __init__(self, proc):
        super().__init__()
        self.proc, self.times = proc, []

    async def on_push_frame(self, data):
        if data.source is self.proc and isinstance(data.frame, (OutputTransportMessageUrgentFrame,
                                                                 TTSAudioRawFrame)):
            self.times.append((data.timestamp / 1e9, data.frame))


def test_paced_frames_go_out_as_their_audio_plays():
    pcm = _speech()
    audio = _tts_frames(pcm, 16000)
    proc = HeadMotionProcessor(lookahead_ms=0)  # pace=True
    seen = _Sent(proc)
    down, _ = asyncio.run(run_test(proc, frames_to_send=[TTSStartedFrame(), *audio, TTSStoppedFrame()],
                                   observers=[seen]))
    _assert_audio_unchanged(audio, _audio_out(down))
    # in order with the audio: only the audio-start message, right before the utterance's audio
    assert _messages(down, OutputTransportMessageFrame) == [{"type": "audio-start", "utterance": 1}]
    first_audio = next(i for i, f in enumerate(down) if isinstance(f, TTSAudioRawFrame))
    assert isinstance(down[first_audio - 1], OutputTransportMessageFrame)
    (utt,) = utterances(_messages(down, OutputTransportMessageUrgentFrame), angles=True)
    ref = reference(pcm, 16000)
    np.testing.assert_allclose(utt["rotvec"][:len(ref)], ref, atol=TOL, rtol=0)
    check_settling(ref, utt["rotvec"][len(ref):], proc.core.settle_frames)

    t0 = next(t for t, f in seen.times if isinstance(f, TTSAudioRawFrame))  # the audio starts playing
    assert all(t - t0 < 0.5 for t, f in seen.times if isinstance(f, TTSAudioRawFrame))  # faster than real time
    for t, f in seen.times:
        if isinstance(f, OutputTransportMessageUrgentFrame) and f.message["type"] == "frames":
            due = f.message["first"] / FPS
            assert t - t0 >= due - 0.02, f"frame {f.message['first']} sent {due - (t - t0):.3f} s early"
            assert t - t0 <= due + 0.5, f"frame {f.message['first']} sent {(t - t0) - due:.3f} s late"


def test_paced_interruption_settles_from_the_last_pose_sent():
    pcm = _speech()
    audio = _tts_frames(pcm, 16000)
    proc = HeadMotionProcessor(lookahead_ms=0)
    frames = [TTSStartedFrame(), *audio, SleepFrame(1.0), InterruptionFrame(), SleepFrame(0.8)]
    down, _ = asyncio.run(run_test(proc, frames_to_send=frames))
    _assert_audio_unchanged(audio, _audio_out(down))
    (utt,) = utterances(_messages(down, OutputTransportMessageUrgentFrame), angles=True)
    ref = reference(pcm, 16000)
    n_settle = proc.core.settle_frames
    shown = len(utt["numbers"]) - n_settle  # frames that went out before the cut: about a second's
    assert 0.6 * FPS <= shown <= 1.6 * FPS
    assert utt["numbers"] == list(range(shown + n_settle))  # no gap, no repeat
    np.testing.assert_allclose(utt["rotvec"][:shown], ref[:shown], atol=TOL, rtol=0)
    check_settling(ref[:shown], utt["rotvec"][shown:], n_settle)
    assert utt["end"]["frames"] == shown + n_settle


def _audio_before(down: list, i: int) -> float:
    """Seconds of TTS audio that went downstream before ``down[i]``."""
    return sum(len(f.audio) / 2 / f.sample_rate for f in down[:i] if isinstance(f, TTSAudioRawFrame))


def test_with_a_lookahead_the_audio_is_held_by_it_and_the_frames_read_ahead():
    """``lookahead_ms=200``: the frames are the stream's with that lookahead; every audio frame
    and everything behind it goes on unchanged and in order, but only once 200 ms more audio has
    come — so a frame's message follows its own audio closely (not 200 ms of audio later, as it
    would with the audio passed on at once); the end lets the audio held go first."""
    from pipecat.frames.frames import TextFrame

    pcm = _speech()
    audio = _tts_frames(pcm, 16000)  # 50 ms each
    text = TextFrame("half way")
    sent = [TTSStartedFrame(), *audio[:20], text, *audio[20:], TTSStoppedFrame()]
    proc = HeadMotionProcessor(pace=False, lookahead_ms=200)
    assert proc.latency_ms == pytest.approx(HeadMotionProcessor(pace=False, lookahead_ms=0).latency_ms + 200)
    down, _ = asyncio.run(run_test(proc, frames_to_send=sent))
    _assert_audio_unchanged(audio, _audio_out(down))
    seq = [f for f in down if not isinstance(f, OutputTransportMessageFrame)]  # the frames it was given
    assert seq.index(text) == seq.index(audio[19]) + 1 == seq.index(audio[20]) - 1  # in order
    assert isinstance(down[-1], TTSStoppedFrame) and down.index(audio[-1]) < len(down) - 1
    msgs = _messages(down, OutputTransportMessageFrame)
    (utt,) = utterances(msgs, angles=True)
    ref = reference(pcm, 16000, lookahead_ms=200)
    np.testing.assert_allclose(utt["rotvec"][:len(ref)], ref, atol=TOL, rtol=0)
    check_settling(ref, utt["rotvec"][len(ref):], proc.core.settle_frames)
    first_audio = next(i for i, f in enumerate(down) if isinstance(f, TTSAudioRawFrame))
    assert down[first_audio - 1].message == {"type": "audio-start", "utterance": 1}
    for i, f in enumerate(down):
        if isinstance(f, OutputTransportMessageFrame) and f.message["type"] == "frames" \
                and not f.message.get("settling") and f.message["first"] < len(ref) - 10:
            ahead = _audio_before(down, i) - f.message["frames"][-1]["time"]
            assert 0.0 < ahead <= 0.04 + 0.1, (f.message["first"], ahead)  # its audio, a chunk or two on


def test_with_a_lookahead_an_interruption_drops_the_audio_held():
    """Cut off after 1.5 s with 200 ms (4 frames of 50 ms) held: those never go downstream (the
    interruption goes first), the head settles from the last frame made, the next reply is fresh."""
    pcm = _speech()
    audio = _tts_frames(pcm, 16000)
    k = 30
    proc = HeadMotionProcessor(pace=False, lookahead_ms=200)
    frames = [TTSStartedFrame(), *audio[:k], SleepFrame(0.3), InterruptionFrame(), SleepFrame(0.2),
              TTSStartedFrame(), *audio, TTSStoppedFrame()]
    down, _ = asyncio.run(run_test(proc, frames_to_send=frames))
    _assert_audio_unchanged(audio[:k - 4] + audio, _audio_out(down))
    first, second = utterances(_messages(down, OutputTransportMessageFrame), angles=True)
    assert first["end"]["audio_seconds"] == pytest.approx(k * 0.05)
    ref = reference(pcm, 16000, lookahead_ms=200)
    np.testing.assert_allclose(second["rotvec"][:len(ref)], ref, atol=TOL, rtol=0)


def test_rtvi_messages_and_other_frames_pass_through():
    from pipecat.frames.frames import OutputAudioRawFrame, TextFrame
    from pipecat.processors.frameworks.rtvi import RTVIServerMessageFrame

    pcm = _speech()
    audio = _tts_frames(pcm, 16000)[:10]
    other = [TextFrame("hello"), OutputAudioRawFrame(audio=b"\0\0" * 160, sample_rate=16000, num_channels=1)]
    proc = HeadMotionProcessor(pace=False, rtvi=True)
    down, _ = asyncio.run(run_test(proc, frames_to_send=[*other, TTSStartedFrame(), *audio, TTSStoppedFrame()]))
    assert down[0] is not None and isinstance(down[0], TextFrame) and down[1].audio == other[1].audio
    msgs = [f.data for f in down if isinstance(f, RTVIServerMessageFrame)]
    assert msgs and msgs[-1]["type"] == "end"
    assert proc.core.frames_made == len(reference(pcm[:8000], 16000))  # the non-TTS audio made no motion


@pytest.mark.parametrize("pace", [True, False])
def test_send_takes_the_messages_instead_of_the_pipeline(pace):
    """``send=`` (e.g. a robot's head in the process, docs/robots.md): the frames and end messages
    go to it, in order and paced as they would go downstream; the audio passes unchanged."""
    pcm = _speech()
    audio = _tts_frames(pcm, 16000)
    got = []

    async def send(message):
        got.append(message)

    proc = HeadMotionProcessor(lookahead_ms=0, pace=pace, send=send)
    down, _ = asyncio.run(run_test(proc, frames_to_send=[TTSStartedFrame(), *audio, TTSStoppedFrame()]))
    _assert_audio_unchanged(audio, _audio_out(down))
    assert _messages(down, OutputTransportMessageUrgentFrame) == []
    assert [m for m in _messages(down, OutputTransportMessageFrame) if m["type"] != "audio-start"] == []
    (utt,) = utterances(got, angles=True)
    ref = reference(pcm, 16000)
    np.testing.assert_allclose(utt["rotvec"][:len(ref)], ref, atol=TOL, rtol=0)
    check_settling(ref, utt["rotvec"][len(ref):], proc.core.settle_frames)


def test_processors_of_one_loop_decide_together_and_keep_their_frames():
    """Three processors in one event loop — different seeds, one reading ahead by the agents'
    default budget, each hearing the user after its utterance — make their decisions together
    through the loop's engine; each sends the messages it sends deciding alone."""
    from pipecat.frames.frames import InputAudioRawFrame

    pcm = _speech()
    user = _speech()[::-1].copy()  # another voice's worth of audio: the same speech reversed

    def frames():
        heard = [InputAudioRawFrame(audio=user[i:i + 800].tobytes(), sample_rate=16000, num_channels=1)
                 for i in range(0, len(user), 800)]
        return [TTSStartedFrame(), *_tts_frames(pcm, 16000), TTSStoppedFrame(), *heard]

    async def main(engine):
        procs = [HeadMotionProcessor(pace=False, lookahead_ms=0, seed=0, engine=engine),
                 HeadMotionProcessor(pace=False, lookahead_ms=0, seed=1, engine=engine),
                 HeadMotionProcessor(pace=False, seed=2, engine=engine)]
        runs = await asyncio.gather(*(run_test(p, frames_to_send=frames()) for p in procs))
        return procs, [_messages(down, OutputTransportMessageFrame) for down, _ in runs]

    together, sent = asyncio.run(main(True))
    alone, sent_alone = asyncio.run(main(False))
    check_decided_together(together, alone, sent, sent_alone)
    for msgs in sent:
        kinds = [m.get("listening", False) for m in msgs if m["type"] == "frames"]
        assert any(kinds) and not all(kinds)  # it spoke, then listened
    assert sent[0] != sent[1]  # the seeds differ
