"""The LiveKit integration with the real ``livekit-agents`` audio output chain, without a server:
real ``rtc.AudioFrame``s of a speech file go through :class:`HeadMotionAudioOutput` to a local
output that plays them, the messages to a local publisher.  Known answers: the audio reaches the
next output unchanged and in order, the frames are the stream's own for the same audio, the head
settles at the end of a reply and when the user interrupts, and the next reply starts fresh.

Runs where ``livekit-agents`` is installed (scripts/test-integrations.sh makes that environment);
elsewhere it is skipped.  Outputs that pass the audio on at once are built with
``lookahead_ms=0``; the agents' default budget (``AGENT_LOOKAHEAD_MS``) holds the audio by as much
(tests/test_agent_lookahead.py, and the lookahead tests here)."""

from __future__ import annotations

import asyncio
import json
import time

import numpy as np
import pytest

pytest.importorskip("livekit.agents", reason="livekit-agents is not installed (pip install \"headmotion[livekit]\")")

from livekit import rtc  # noqa: E402
from livekit.agents import AgentSession  # noqa: E402
from livekit.agents.voice import io  # noqa: E402

from agent_helpers import FPS, TOL, check_decided_together, check_settling, reference, utterances  # noqa: E402
from agent_helpers import speech_pcm as _speech  # noqa: E402

from headmotion.integrations.livekit import (  # noqa: E402
    TOPIC,
    HeadMotionAudioOutput,
    attach_head_motion,
    room_sender,
)



class PlayingOutput(io.AudioOutput):
    """The next output in the chain: keeps the frames it is given and, like the room's output,
    reports a segment finished when flushed (all played) or cleared (interrupted)."""

    def __init__(self, sample_rate: int | None = None):
        super().__init__(label="Playing", capabilities=io.AudioOutputCapabilities(pause=True),
                         sample_rate=sample_rate)
        self.frames: list[rtc.AudioFrame] = []
        self.events: list[str] = []
        self._segment: float | None = None  # seconds captured in the open segment

    async def capture_frame(self, frame: rtc.AudioFrame) -> None:
        await super().capture_frame(frame)
        self.frames.append(frame)
        self._segment = (self._segment or 0.0) + frame.duration

    def flush(self) -> None:
        super().flush()
        self.events.append("flush")
        self._finish(interrupted=False)

    def clear_buffer(self) -> None:
        self.events.append("clear")
        self._finish(interrupted=True)

    def _finish(self, *, interrupted: bool) -> None:
        if self._segment is not None:
            self.on_playback_finished(playback_position=self._segment, interrupted=interrupted)
            self._segment = None


class Publisher:
    """A local stand-in for the room: the messages as JSON text, with when they went out."""

    def __init__(self):
        self.sent: list[tuple[float, dict]] = []

    async def __call__(self, message: dict) -> None:
        text = json.dumps(message, separators=(",", ":"))  # what room_sender publishes
        self.sent.append((time.monotonic(), json.loads(text)))

    @property
    def messages(self) -> list[dict]:
        return [m for _, m in self.sent]




def _audio_frames(pcm: np.ndarray, rate: int, chunk_s: float = 0.05, channels: int = 1) -> list[rtc.AudioFrame]:
    n = int(rate * chunk_s)
    out = []
    for i in range(0, len(pcm), n):
        c = pcm[i:i + n]
        data = np.repeat(c, channels) if channels > 1 else c  # the same signal on every channel
        out.append(rtc.AudioFrame(data=data.tobytes(), sample_rate=rate, num_channels=channels,
                                  samples_per_channel=len(c)))
    return out








def _assert_passed_on(sent: list, received: list) -> None:
    assert len(received) == len(sent)
    for a, b in zip(sent, received):
        assert b is a  # the same frame objects, in order, untouched
        assert bytes(b.data) == bytes(a.data) and b.sample_rate == a.sample_rate


async def _speak(out: HeadMotionAudioOutput, frames: list, *, flush: bool = True) -> None:
    for f in frames:
        await out.capture_frame(f)
    if flush:
        out.flush()


@pytest.mark.parametrize("rate,channels", [(16000, 1), (24000, 1), (48000, 2)])
def test_reply_frames_equal_the_stream_and_audio_passes_unchanged(rate, channels):
    pcm = _speech(rate)
    frames = _audio_frames(pcm, rate, channels=channels)

    async def main():
        sink, pub = PlayingOutput(), Publisher()
        out = HeadMotionAudioOutput(sink, send=pub, pace=False, lookahead_ms=0)
        await _speak(out, frames)
        assert await out.wait_sent(5.0)
        await out.aclose()
        return sink, pub, out

    sink, pub, out = asyncio.run(main())
    _assert_passed_on(frames, sink.frames)
    assert sink.events == ["flush"]
    (utt,) = utterances(pub.messages)
    ref = reference(pcm, rate)
    n, n_settle = len(ref), out.core.settle_frames
    assert n == pytest.approx(len(pcm) / rate * FPS, abs=2)
    assert utt["numbers"] == list(range(n + n_settle))
    np.testing.assert_allclose(utt["rotvec"][:n], ref, atol=TOL, rtol=0)
    check_settling(ref, utt["rotvec"][n:], n_settle)
    assert utt["end"] == {"type": "end", "frames": n + n_settle, "audio_seconds": round(len(pcm) / rate, 4),
                          "utterance": 1}


def test_interruption_settles_and_the_next_reply_starts_fresh():
    pcm = _speech(24000)
    frames = _audio_frames(pcm, 24000)
    k = 30

    async def main():
        sink, pub = PlayingOutput(), Publisher()
        out = HeadMotionAudioOutput(sink, send=pub, pace=False, lookahead_ms=0)
        await _speak(out, frames[:k], flush=False)
        out.clear_buffer()  # the user cut the agent off
        out.flush()         # the agent's speech handle ends the segment after the clear
        await _speak(out, frames)
        assert await out.wait_sent(5.0)
        await out.aclose()
        return sink, pub, out

    sink, pub, out = asyncio.run(main())
    _assert_passed_on(frames[:k] + frames, sink.frames)
    first, second = utterances(pub.messages)
    cut = reference(pcm[:k * 1200], 24000, flush=False)
    m, n_settle = len(cut), out.core.settle_frames
    assert first["numbers"] == list(range(m + n_settle))
    np.testing.assert_allclose(first["rotvec"][:m], cut, atol=TOL, rtol=0)
    check_settling(cut, first["rotvec"][m:], n_settle)
    assert first["end"]["frames"] == m + n_settle
    ref = reference(pcm, 24000)
    assert second["numbers"] == list(range(len(ref) + n_settle))
    np.testing.assert_allclose(second["rotvec"][:len(ref)], ref, atol=TOL, rtol=0)
    check_settling(ref, second["rotvec"][len(ref):], n_settle)


def test_paced_frames_go_out_as_the_audio_plays_and_settle_on_interruption():
    pcm = _speech(24000)
    frames = _audio_frames(pcm, 24000)

    async def main():
        sink, pub = PlayingOutput(), Publisher()
        out = HeadMotionAudioOutput(sink, send=pub, lookahead_ms=0)  # pace=True
        t0 = time.monotonic()
        await _speak(out, frames, flush=False)  # the whole reply at once, faster than real time
        await asyncio.sleep(1.0)
        out.clear_buffer()
        out.flush()
        assert await out.wait_sent(3.0)
        await out.aclose()
        return t0, sink, pub, out

    t0, sink, pub, out = asyncio.run(main())
    _assert_passed_on(frames, sink.frames)
    (utt,) = utterances(pub.messages)
    n_settle = out.core.settle_frames
    shown = len(utt["numbers"]) - n_settle
    assert 0.6 * FPS <= shown <= 1.6 * FPS  # about the second of audio that played
    assert utt["numbers"] == list(range(shown + n_settle))
    ref = reference(pcm, 24000)
    np.testing.assert_allclose(utt["rotvec"][:shown], ref[:shown], atol=TOL, rtol=0)
    check_settling(ref[:shown], utt["rotvec"][shown:], n_settle)
    for t, msg in pub.sent:
        if msg["type"] == "frames" and msg["first"] < shown:
            due = msg["first"] / FPS
            assert due - 0.02 <= t - t0 <= due + 0.5, (msg["first"], t - t0)
    settle_times = [t for t, msg in pub.sent if msg["type"] == "frames" and msg["first"] >= shown]
    assert settle_times[-1] - settle_times[0] == pytest.approx((n_settle - 1) / FPS, abs=0.25)  # eased, not dumped


def test_with_a_lookahead_the_audio_is_held_by_it_and_the_frames_read_ahead():
    """``lookahead_ms=200``: an audio frame goes on to the next output once 200 ms more audio has
    come (4 frames of 50 ms), the rest at the reply's end, before the next output's flush; the
    frames are the stream's with that lookahead; the next reply waits for the held audio."""
    pcm = _speech(24000)
    frames = _audio_frames(pcm, 24000)

    async def main():
        sink, pub = PlayingOutput(), Publisher()
        out = HeadMotionAudioOutput(sink, send=pub, pace=False, lookahead_ms=200)
        await _speak(out, frames[:10], flush=False)
        held = len(sink.frames)
        out.flush()
        await _speak(out, frames)  # the next reply comes right after the flush
        assert await out.wait_sent(5.0)
        await asyncio.wait_for(out.wait_for_playout(), 2.0)
        await out.aclose()
        return sink, pub, out, held

    sink, pub, out, held = asyncio.run(main())
    assert held == 6 and sink.events == ["flush", "flush"]
    _assert_passed_on(frames[:10] + frames, sink.frames)
    first, second = utterances(pub.messages)
    ref = reference(pcm, 24000, lookahead_ms=200)
    np.testing.assert_allclose(second["rotvec"][:len(ref)], ref, atol=TOL, rtol=0)
    short = reference(pcm[:10 * 1200], 24000, lookahead_ms=200)  # the first reply: its 0.5 s alone
    np.testing.assert_allclose(first["rotvec"][:len(short)], short, atol=TOL, rtol=0)
    from headmotion.live.core import HeadMotionCore

    assert out.core.latency_ms == pytest.approx(HeadMotionCore("stream").latency_ms + 200)


def test_with_a_lookahead_an_interruption_drops_the_audio_held_and_the_reply_ends():
    """Cut off with audio held (the agent flushes, then clears at once): the held audio never
    reaches the next output, which still ends its segment; a reply cut off before any of its audio
    went on ends all the same (no wait for a playback that never comes)."""
    pcm = _speech(16000)
    frames = _audio_frames(pcm, 16000)

    async def main():
        sink, pub = PlayingOutput(), Publisher()
        out = HeadMotionAudioOutput(sink, send=pub, pace=False, lookahead_ms=200)
        await _speak(out, frames[:30], flush=False)
        out.flush()
        out.clear_buffer()
        await asyncio.wait_for(out.wait_for_playout(), 2.0)
        passed = len(sink.frames)
        await _speak(out, frames[:2], flush=False)  # 100 ms: all of it held
        out.clear_buffer()
        out.flush()
        await asyncio.wait_for(out.wait_for_playout(), 2.0)
        assert await out.wait_sent(5.0)
        await out.aclose()
        return sink, pub, passed

    sink, pub, passed = asyncio.run(main())
    assert passed == 26 and len(sink.frames) == 26
    _assert_passed_on(frames[:26], sink.frames)
    first, second = utterances(pub.messages)
    assert first["end"]["audio_seconds"] == pytest.approx(1.5) and second["end"]["audio_seconds"] == pytest.approx(0.1)


def test_pause_holds_the_frames_with_the_audio():
    pcm = _speech(16000)
    frames = _audio_frames(pcm, 16000)[:20]  # 1 s

    async def main():
        sink, pub = PlayingOutput(), Publisher()
        out = HeadMotionAudioOutput(sink, send=pub, lookahead_ms=0)
        began = time.monotonic()  # the audio plays from its first frame, not before this
        await _speak(out, frames, flush=False)
        await asyncio.sleep(0.3)
        out.pause()
        t_pause = time.monotonic()
        n_paused = len(pub.sent)
        await asyncio.sleep(0.5)
        assert len(pub.sent) == n_paused  # nothing goes out while the audio is paused
        out.resume()
        t_resume = time.monotonic()
        out.flush()
        assert await out.wait_sent(5.0)
        await out.aclose()
        return pub, n_paused, t_resume - t_pause, began

    pub, n_paused, paused, began = asyncio.run(main())
    assert 0 < n_paused < len(pub.sent)
    (utt,) = utterances(pub.messages)
    np.testing.assert_allclose(utt["rotvec"][0], reference(pcm[:16000], 16000)[0], atol=TOL)
    # the frames after the pause went out that much later than their audio time; timed from
    # before the audio began (the time frame 0 went out is itself late by the loop's jitter)
    for t, m in pub.sent[n_paused:]:
        if m["type"] == "frames":
            assert t - began >= m["first"] / FPS + paused - 0.03, (m["first"], t - began, paused)


def test_outputs_of_one_loop_decide_together_and_keep_their_frames():
    """Three outputs in one event loop (different seeds, one reading ahead by the agents' default
    budget, one interrupted mid-reply) make their decisions together through the loop's engine;
    each publishes the messages it publishes deciding alone."""
    pcm = _speech(16000)

    async def one(out, cut: bool):
        frames = _audio_frames(pcm, 16000)
        if cut:  # the user cuts in while the reply's last chunk is being read (with the engine:
            await _speak(out, frames[:29], flush=False)  # its push waits for a tick, finished first)
            task = asyncio.ensure_future(out.capture_frame(frames[29]))
            await asyncio.sleep(0)
            out.clear_buffer()
            await task
        await _speak(out, frames)
        await asyncio.wait_for(out.wait_for_playout(), 2.0)  # the held audio went on, the reply ended
        assert await out.wait_sent(5.0)
        await out.aclose()

    async def main(engine):
        pubs = [Publisher() for _ in range(3)]
        outs = [HeadMotionAudioOutput(PlayingOutput(), send=pubs[0], pace=False, lookahead_ms=0, seed=0, engine=engine),
                HeadMotionAudioOutput(PlayingOutput(), send=pubs[1], pace=False, seed=1, engine=engine),
                HeadMotionAudioOutput(PlayingOutput(), send=pubs[2], pace=False, lookahead_ms=0, seed=2,
                                      engine=engine)]
        await asyncio.gather(*(one(o, cut=k == 2) for k, o in enumerate(outs)))
        return outs, [p.messages for p in pubs]

    together, sent = asyncio.run(main(True))
    alone, sent_alone = asyncio.run(main(False))
    check_decided_together(together, alone, sent, sent_alone)
    assert len(utterances(sent[2])) == 2 and sent[0] != sent[1]


def test_attach_to_an_agent_session_and_publish_to_a_room():
    class Participant:
        def __init__(self):
            self.packets = []

        async def publish_data(self, payload, *, reliable=True, destination_identities=(), topic=""):
            self.packets.append((payload, reliable, topic))

    class Room:
        local_participant = Participant()

    async def main():
        session = AgentSession()
        with pytest.raises(Exception, match="after `await session.start"):
            attach_head_motion(session, Room())
        sink = PlayingOutput(sample_rate=24000)
        session.output.audio = sink  # what session.start puts there for a room
        room = Room()
        out = attach_head_motion(session, room, pace=False, lookahead_ms=0)
        assert session.output.audio is out and out.sample_rate == 24000
        pcm = _speech(24000)[:24000]
        await _speak(out, _audio_frames(pcm, 24000))
        assert await out.wait_sent(5.0)
        await out.aclose()
        return room.local_participant.packets

    packets = asyncio.run(main())
    assert packets and all(topic == TOPIC and reliable for _, reliable, topic in packets)
    msgs = [json.loads(p) for p, _, _ in packets]
    assert msgs[-1]["type"] == "end" and msgs[0]["type"] == "frames" and msgs[0]["first"] == 0
    assert callable(room_sender(Room()))
