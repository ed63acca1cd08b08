"""The agent core listens: the user's audio, while the agent is silent, opens a listening turn
(numbered as an utterance) that eases in from the pose shown, listens as synthesize(hear=) does,
and ends when the agent speaks again, whose speech eases in from the listening pose."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from headmotion.live.core import FrameBatch, HeadMotionCore, UtteranceEnd
from headmotion.live.pacing import Pacer

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "speech"


@pytest.fixture(scope="module")
def voices():
    from headmotion.io import load_audio

    a = load_audio(EXAMPLES / "speech_female.wav", sample_rate=16000).samples[:3 * 16000]
    b = load_audio(EXAMPLES / "speech_male.wav", sample_rate=16000).samples
    return a, b


def test_a_listening_turn_listens_and_hands_the_turn_back_without_a_jump(voices):
    a, b = voices
    core = HeadMotionCore("stream", seed=0)
    for i in range(0, len(a), 320):
        core.push(a[i:i + 320], 16000)
    spoken = [x for x in core.end() if isinstance(x, FrameBatch)]
    rest = spoken[-1].rotvec[-1]
    assert not core.listening
    heard = [core.hear(b[i:i + 320], 16000) for i in range(0, len(b), 320)]
    assert core.listening and heard[0].first == 0
    rv = np.vstack([h.rotvec for h in heard])
    assert np.degrees(np.linalg.norm(rv[0] - rest)) < 1.0        # eased in from the rest pose
    # past the easing the frames are the listening stream's: synthesize(silence, hear=user)
    from headmotion.synthesis import open_stream

    s = open_stream("stream", seed=0, sample_rate=16000)
    ref = []
    for i in range(0, len(b), 320):
        s.hear(b[i:i + 320])
        ref.append(s.push(np.zeros(len(b[i:i + 320]), np.float32)).rotvec)
    ref = np.vstack(ref)
    n = core.settle_frames
    np.testing.assert_array_equal(rv[n:], ref[n:len(rv)])
    assert len(s._listener.nod_starts) >= 1                      # it nodded at the user's cues
    end = core.end_listening()
    assert isinstance(end[0], UtteranceEnd) and end[0].frames == len(rv) and not core.listening
    first = core.push(a[:3200], 16000).rotvec
    assert np.degrees(np.linalg.norm(first[0] - rv[-1])) < 1.5    # the reply eases in from the listening pose


def test_the_pacer_listens_only_after_the_agents_audio_has_played(voices):
    a, b = voices
    clock = [0.0]
    pacer = Pacer(HeadMotionCore("stream", seed=0), clock=lambda: clock[0])
    pacer.audio(a, 16000, now=0.0)        # 3 s of reply handed over at once
    pacer.end(now=0.0)
    assert len(pacer.hear(b[:320], 16000, now=1.0)) == 0 and not pacer.core.listening
    t = pacer.busy_until() + 0.01
    got = []
    for i in range(0, 16000, 320):
        got.append(pacer.hear(b[i:i + 320], 16000, now=t + i / 16000))
    assert pacer.core.listening and sum(len(g) for g in got) > 0
    msgs = pacer.due(now=t + 2.0)
    frames = [m for m in msgs if m["type"] == "frames"]
    assert frames and frames[0]["first"] == 0
    # the listening turn is the second utterance, its frames marked as not following the agent's audio
    listen = [m for m in frames if m["utterance"] == 2]
    assert listen and all(m.get("listening") and "settling" not in m for m in listen)
    assert all(m["utterance"] == 1 and "listening" not in m for m in frames if m not in listen)
    assert any(m.get("settling") for m in frames if m not in listen)  # the reply's settling
    pacer.audio(a[:1600], 16000, now=t + 2.0)   # the agent speaks: the listening turn ends
    assert pacer.audio_started == 3
    msgs = pacer.due(now=t + 2.0)
    assert [m["type"] for m in msgs][0] == "end"
