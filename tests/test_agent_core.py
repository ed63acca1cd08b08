"""The agent integrations' transport-independent core (:mod:`headmotion.live.core`),
without any agent framework: known answers for pushing speech (at the model's rate and resampled),
the messages (``headmotion serve``'s stream messages), the settling of the head at the end of an
utterance and on an interruption, the pacing of the frames to the audio's playback, and the
imports (headmotion never imports Pipecat or LiveKit; without them, the integration modules say
which extra to install)."""

from __future__ import annotations

import asyncio
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import MissingDependencyError, ParameterError, SampleRateError
from headmotion.live.core import FrameBatch, HeadMotionCore, UtteranceEnd, pcm16_to_float, settle_path
from headmotion.live.pacing import PacedSender, Pacer
from headmotion.io.resampler import Resampler
from headmotion.synthesis import load_model

ROOT = Path(__file__).resolve().parents[1]
FPS = 25.0


@pytest.fixture(scope="module")
def speech():
    import soundfile as sf

    x, sr = sf.read(ROOT / "examples" / "speech" / "short.wav", dtype="float32")
    assert sr == 16000
    return x


@pytest.fixture(scope="module")
def model():
    return load_model("stream")


def _direct(model, x, rate=16000, chunk=320, quality="HQ", flush=True):
    """The frames of ``model.stream()`` for ``x`` pushed directly, resampled as the core does."""
    stream = model.stream(seed=0)
    rs = Resampler(rate, int(model.sample_rate), quality=quality)
    out = [np.asarray(stream.push(rs(x[i:i + chunk])).rotvec).reshape(-1, 3) for i in range(0, len(x), chunk)]
    if flush:
        out.append(np.asarray(stream.push(rs(np.zeros(0, np.float32), last=True)).rotvec).reshape(-1, 3))
        out.append(np.asarray(stream.flush().rotvec).reshape(-1, 3))
    return np.vstack(out)


def _push_all(core, x, rate=16000, chunk=320):
    batches = [core.push(x[i:i + chunk], rate) for i in range(0, len(x), chunk)]
    return batches


def _rows(batches):
    return np.vstack([b.rotvec for b in batches if isinstance(b, FrameBatch)] or [np.zeros((0, 3))])


def test_push_at_the_model_rate_gives_the_streams_frames(model, speech):
    core = HeadMotionCore(model)
    assert (core.fps, core.sample_rate, core.settle_frames) == (25.0, 16000, 13)
    assert core.latency_ms == pytest.approx(40.0)  # the shipped stream: a frame is final once its Praat window (centre + 20 ms) is in
    batches = _push_all(core, speech)
    ends = core.end()
    ref = _direct(model, speech)
    got = np.vstack([_rows(batches)] + [b.rotvec for b in ends if isinstance(b, FrameBatch) and not b.settling])
    np.testing.assert_array_equal(got, ref)  # the same numbers: the same stream
    assert len(ref) == round(len(speech) / 16000 * FPS)  # 25 frames a second (69 for 2.78 s)
    firsts = [b.first for b in batches if len(b)]
    assert firsts == sorted(firsts) and batches[-1].audio_time == pytest.approx(len(speech) / 16000)


@pytest.mark.parametrize("rate,resample,quality", [(24000, "exact", "HQ"), (44100, "exact", "HQ"),
                                                   (24000, "fast", "LQ")])
def test_push_resamples_as_the_serve_stream_does(model, speech, rate, resample, quality):
    import soxr

    x = soxr.resample(speech, 16000, rate, quality="HQ").astype(np.float32)
    core = HeadMotionCore(model, resample=resample)
    chunk = rate // 50
    got = np.vstack([_rows(_push_all(core, x, rate, chunk)),
                     *[b.rotvec for b in core.end() if isinstance(b, FrameBatch) and not b.settling]])
    np.testing.assert_allclose(got, _direct(model, x, rate, chunk, quality), atol=1e-12, rtol=0)
    assert len(got) == pytest.approx(len(x) / rate * FPS, abs=1)


def test_samples_formats():
    pcm = np.array([0, 16384, -32768, 32767], dtype="<i2")
    np.testing.assert_array_equal(pcm16_to_float(pcm.tobytes()), [0.0, 0.5, -1.0, 32767 / 32768])
    stereo = np.array([16384, 0, -16384, -16384], dtype="<i2")  # two frames of two channels
    np.testing.assert_array_equal(pcm16_to_float(memoryview(stereo.tobytes()), 2), [0.25, -0.5])
    with pytest.raises(ParameterError):
        pcm16_to_float(stereo[:3].tobytes(), 2)
    with pytest.raises(ParameterError):
        pcm16_to_float(b"", 0)


def test_two_channels_are_mixed_down(model, speech):
    a, b = HeadMotionCore(model), HeadMotionCore(model)
    ra = _rows(_push_all(a, speech))
    rb = _rows([b.push(np.column_stack([speech, speech])[i:i + 320], 16000) for i in range(0, len(speech), 320)])
    np.testing.assert_array_equal(ra, rb)


def test_messages_are_the_serve_streams(model, speech):
    from headmotion.serve.stream import frames_message

    core = HeadMotionCore(model)
    batch = core.push(speech[:16000], 16000)
    assert len(batch)
    expected = json.loads(frames_message(batch.rotvec, FPS, batch.first, batch.audio_time, "json"))
    assert batch.message() == expected
    assert set(expected) == {"type", "first", "fps", "audio_time", "frames"}
    assert UtteranceEnd(80, 2.777125).message() == {"type": "end", "frames": 80, "audio_seconds": 2.7771}


def test_end_flushes_then_settles_to_rest(model, speech):
    core = HeadMotionCore(model)
    made = _rows(_push_all(core, speech))
    items = core.end()
    assert not core.speaking
    *batches, end = items
    assert isinstance(end, UtteranceEnd) and not end.interrupted
    settle = batches[-1]
    assert settle.settling and len(settle) == core.settle_frames and settle.first == core.frames_made
    speech_frames = core.frames()
    assert len(speech_frames) == core.frames_made >= len(made)
    assert end.frames == core.frames_made + core.settle_frames
    assert end.audio_seconds == pytest.approx(len(speech) / 16000)
    np.testing.assert_array_equal(settle.rotvec[-1], [0.0, 0.0, 0.0])  # the rest pose, exactly
    path = np.vstack([speech_frames[-1:], settle.rotvec])
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    bound = 1.5 * np.linalg.norm(speech_frames[-1]) / core.settle_frames + np.linalg.norm(
        speech_frames[-1] - speech_frames[-2])
    assert steps.max() <= bound + 1e-12 and steps.max() < math.radians(1.0)
    assert core.end() == []  # nothing open


def test_interrupt_drops_the_held_frames_and_the_next_utterance_is_fresh(model, speech):
    core = HeadMotionCore(model)
    made = _rows(_push_all(core, speech[:24000]))
    settle, end = core.interrupt()
    assert end.interrupted and end.frames == len(made) + core.settle_frames
    assert settle.first == len(made) and core.frames_made == len(made)  # the held frames were dropped
    np.testing.assert_array_equal(settle.rotvec[-1], 0.0)
    assert core.interrupt() == []  # already settled
    again = _rows(_push_all(core, speech))  # a fresh stream, frames numbered from 0 again
    np.testing.assert_array_equal(again, _direct(model, speech, flush=False))
    assert _push_all(core, speech[:320])[0].first == len(again)


def test_interrupt_settles_from_the_last_frame_shown(model, speech):
    core = HeadMotionCore(model)
    _push_all(core, speech)
    frames = core.frames()
    settle, end = core.interrupt(shown=20)
    assert settle.first == 20 and end.frames == 20 + core.settle_frames
    expected = settle_path(frames[19], frames[18], np.zeros(3), core.settle_frames)
    np.testing.assert_array_equal(settle.rotvec, expected)
    # an ended utterance whose audio still plays may be cut off too
    core2 = HeadMotionCore(model)
    _push_all(core2, speech)
    core2.end()
    assert core2.interrupt() == []
    settle2, _ = core2.interrupt(shown=10)
    assert settle2.first == 10
    assert core2.interrupt(shown=0)[-1].frames == 0  # nothing shown: nothing to settle from


def test_settle_path_known_answers():
    n = 4
    s = np.arange(1, n + 1) / n
    h00 = 2 * s ** 3 - 3 * s ** 2 + 1
    h10 = s ** 3 - 2 * s ** 2 + s
    last = np.array([0.1, -0.05, 0.02])
    # from rest at rest: a scaled rotation vector (about one axis the rest pose is identity)
    np.testing.assert_allclose(settle_path(last, last, np.zeros(3), n), h00[:, None] * last, atol=1e-15)
    # the head's own speed carries into the settling: the Hermite tangent is n × the last step
    prev = np.array([0.09, -0.05, 0.02])
    np.testing.assert_allclose(settle_path(last, prev, np.zeros(3), n),
                               h00[:, None] * last + h10[:, None] * n * (last - prev), atol=1e-12)
    rest = np.array([0.0, 0.2, 0.0])
    p = settle_path(rest, rest, rest, n)
    np.testing.assert_allclose(p, np.tile(rest, (n, 1)), atol=1e-15)


def test_settles_to_the_offset_and_still_holds(model, speech):
    from headmotion.rotations import pitch_yaw_roll_to_rotvec

    core = HeadMotionCore(model, offset_degrees="-3,5,0")
    rest = pitch_yaw_roll_to_rotvec(math.radians(-3), math.radians(5), 0.0)[0]
    np.testing.assert_allclose(core.rest_pose, rest)
    _push_all(core, speech)
    settle = [b for b in core.end() if isinstance(b, FrameBatch) and b.settling][0]
    np.testing.assert_allclose(settle.rotvec[-1], rest, atol=1e-15)
    still = HeadMotionCore(model, still=True)
    rows = _rows(_push_all(still, speech))
    np.testing.assert_allclose(rows, 0.0, atol=1e-15)
    assert HeadMotionCore(model, settle_s=0).end() == []
    nothing = HeadMotionCore(model, settle_s=0)
    _push_all(nothing, speech[:8000])
    assert [type(i).__name__ for i in nothing.end()][-1] == "UtteranceEnd"
    assert all(not getattr(i, "settling", False) for i in nothing.end())


def test_bad_parameters_are_refused(model, speech):
    with pytest.raises(ParameterError, match="resample"):
        HeadMotionCore(model, resample="best")
    with pytest.raises(ParameterError, match="settle_s"):
        HeadMotionCore(model, settle_s=-1)
    with pytest.raises(ParameterError, match="seed"):
        HeadMotionCore(model, seed=-1)
    with pytest.raises(ParameterError, match="gain"):
        HeadMotionCore(model, gain=-1)
    with pytest.raises(ParameterError, match="not both"):
        from headmotion.synthesis import Controls

        HeadMotionCore(model, controls=Controls(), gain=2)
    core = HeadMotionCore(model)
    with pytest.raises(ParameterError, match="sample_rate"):
        core.push(speech[:320], 0)
    with pytest.raises(ParameterError, match="NaN"):
        core.push(np.full(320, np.nan, np.float32), 16000)
    core.push(speech[:320], 16000)
    with pytest.raises(SampleRateError, match="24000"):
        core.push(speech[:320], 24000)
    with pytest.raises(ParameterError, match="delay_s"):
        Pacer(core, delay_s=-0.1)


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def _frames_of(messages):
    out = []
    for m in messages:
        if m["type"] == "frames":
            out += [f["frame"] for f in m["frames"]]
    return out


def test_pacer_sends_each_frame_when_its_audio_plays(model, speech):
    clock = Clock()
    pacer = Pacer(HeadMotionCore(model), clock=clock)
    for i in range(0, len(speech), 8000):  # the whole reply at once, faster than real time
        pacer.audio(speech[i:i + 8000], 16000)
    pacer.end()
    n = pacer.core.frames_made
    assert pacer.next_due() == pytest.approx(100.0)
    assert _frames_of(pacer.due(100.0)) == [0]
    assert _frames_of(pacer.due(100.0 + 0.999)) == list(range(1, 25))  # frame i at i / 25 s
    msgs = pacer.due(100.0 + n / FPS - 1e-9)
    assert _frames_of(msgs) == list(range(25, n))
    msgs = pacer.due(1e9)
    assert _frames_of(msgs) == list(range(n, n + 13)) and msgs[-1]["type"] == "end"
    assert pacer.pending == 0 and pacer.next_due() is None


def test_pacer_interruption_settles_from_the_last_frame_sent(model, speech):
    clock = Clock()
    pacer = Pacer(HeadMotionCore(model), clock=clock)
    pacer.audio(speech, 16000)
    sent = _frames_of(pacer.due(100.5))
    assert sent == list(range(13))
    clock.t = 100.5
    pacer.interrupt()
    msgs = pacer.due(100.5)
    assert _frames_of(msgs) == [13]  # the settling starts at once, numbered on from the last sent
    expected = settle_path(pacer.core.frames()[12], pacer.core.frames()[11], np.zeros(3), 13)
    np.testing.assert_allclose(msgs[0]["frames"][0]["rotvec"], expected[0], atol=5e-7)
    rest = pacer.due(100.5 + 12 / FPS)
    assert _frames_of(rest) == list(range(14, 26)) and rest[-1] == {"type": "end", "frames": 26,
                                                                      "audio_seconds": 2.7771, "utterance": 1}
    assert all(m["utterance"] == 1 and m["settling"] and m["interrupted"] for m in msgs + rest[:-1])
    assert rest[-2]["frames"][-1]["rotvec"] == [0.0, 0.0, 0.0]
    pacer.interrupt()  # nothing spoken: nothing happens
    assert pacer.pending == 0


def test_pacer_next_utterance_after_the_audio_and_pause(model, speech):
    clock = Clock()
    pacer = Pacer(HeadMotionCore(model), clock=clock, delay_s=0.1)
    pacer.audio(speech[:16000], 16000)  # 1 s
    pacer.end()
    assert pacer.next_due() == pytest.approx(100.1)  # delay_s later than the audio
    pacer.audio(speech[:16000], 16000)  # the next reply queues behind the first's audio
    assert pacer.utterance == 2
    msgs = pacer.due(1e9)
    ends = [i for i, m in enumerate(msgs) if m["type"] == "end"]
    assert len(ends) == 1  # the first's settling gave way to the second's speech; its end went out
    first = _frames_of(msgs[:ends[0]])
    assert first == list(range(len(first))) and len(first) == 25
    assert _frames_of(msgs[ends[0] + 1:])[0] == 0
    # pause / resume move what waits by the pause
    pacer2 = Pacer(HeadMotionCore(model), clock=clock)
    pacer2.audio(speech[:16000], 16000)
    assert _frames_of(pacer2.due(100.2)) == list(range(0, 6))
    pacer2.pause(100.2)
    assert pacer2.due(1e9) == [] and pacer2.next_due() is None
    pacer2.resume(100.7)  # half a second later: frame i now at 100.5 + i / 25
    assert pacer2.next_due() == pytest.approx(100.5 + 6 / FPS)
    assert _frames_of(pacer2.due(101.1 - 1e-9)) == list(range(6, 15))


def test_pacer_unpaced_and_rate_change(model, speech):
    pacer = Pacer(HeadMotionCore(model), pace=False)
    pacer.audio(speech[:16000], 16000)
    pacer.interrupt()
    msgs = pacer.due()
    assert _frames_of(msgs) == list(range(pacer.core.frames_made + 13)) and msgs[-1]["type"] == "end"
    pacer.audio(speech[:8000], 16000)
    pacer.audio(speech[:8000], 8000)  # another rate: that utterance ends, another begins
    assert pacer.utterance == 3
    types = [m["type"] for m in pacer.drain()]
    assert types.count("end") == 1 and types[-1] == "frames"


def test_paced_sender_sends_in_time_and_survives_a_failing_send(model, speech):
    async def main():
        got, calls = [], []

        async def send(message):
            calls.append(message["type"])
            if len(calls) == 1:
                raise ConnectionError("the data channel is down")
            got.append(message)

        pacer = Pacer(HeadMotionCore(model, settle_s=0.2))
        sender = PacedSender(pacer, send)
        sender.start()
        pacer.audio(speech[:4000], 16000)  # 0.25 s
        pacer.end()
        sender.wake()
        assert await sender.wait_idle(3.0)
        await sender.aclose()
        return got, calls

    got, calls = asyncio.run(main())
    assert len(calls) == len(got) + 1 and got[-1]["type"] == "end"


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          cwd=ROOT)


def test_headmotion_never_imports_the_frameworks():
    out = _run("import sys, headmotion, headmotion.integrations, headmotion.live.core\n"
               "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pipecat', 'livekit')))")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("module,package,extra", [("pipecat", "pipecat", "pipecat"),
                                                  ("livekit", "livekit", "livekit")])
def test_without_the_framework_the_error_names_the_extra(module, package, extra):
    code = (f"import sys; sys.modules[{package!r}] = None\n"  # as if it were not installed
            "from headmotion.errors import MissingDependencyError\n"
            "try:\n"
            f"    import headmotion.integrations.{module}\n"
            "except MissingDependencyError as exc:\n"
            "    print('MissingDependencyError', exc.exit_code, exc)\n")
    out = _run(code)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("MissingDependencyError 3 ")
    assert f'pip install "headmotion[{extra}]"' in out.stdout
    assert issubclass(MissingDependencyError, Exception)


def test_a_long_utterance_keeps_only_the_last_frames(model, speech, monkeypatch):
    """Memory stays bounded: with KEEP_S at 1 s (25 frames) the core holds at most 50 frames of an
    utterance, still settles from the frame shown when it is kept, and from the oldest kept
    frame when the one named is older."""
    import headmotion.live.core as core_module

    monkeypatch.setattr(core_module, "KEEP_S", 1.0)
    core = HeadMotionCore(model)
    x = np.concatenate([speech] * 3)
    _push_all(core, x)
    made = core.frames_made
    kept = core.frames()
    assert made > 60 and 25 <= len(kept) <= 50 and core.kept_from == made - len(kept)
    settle, end = core.interrupt(shown=made - 3)
    np.testing.assert_array_equal(settle.rotvec, settle_path(kept[-4], kept[-5], np.zeros(3), core.settle_frames))
    core = HeadMotionCore(model)
    _push_all(core, x)
    oldest = core.kept_from
    settle, end = core.interrupt(shown=1)  # long gone: the oldest kept frame stands in
    assert settle.first == oldest + 1 and end.frames == oldest + 1 + core.settle_frames


def test_hear_along_feeds_the_utterances_stream(model, speech):
    """Heard audio on the utterance's timeline gives what the library's stream gives with the same
    heard audio; without heard_rate it is refused with a clear error."""
    from headmotion.synthesis import open_stream

    core = HeadMotionCore(model, settle_s=0, heard_rate=16000)
    with pytest.raises(ParameterError, match="no utterance"):
        core.hear_along(speech[:320])
    core.begin(16000)

    stream = open_stream(model, seed=0, sample_rate=16000, heard_rate=16000)
    got, want = [], []
    quiet = np.zeros(320, np.float32)
    for i in range(0, len(speech), 320):
        core.hear_along(speech[i:i + 320])
        stream.hear(speech[i:i + 320])
        got.append(core.push(quiet, 16000).rotvec)
        want.append(stream.push(quiet).rotvec)
    np.testing.assert_array_equal(np.vstack(got), np.vstack(want))
    with pytest.raises(ParameterError, match="heard_rate"):
        HeadMotionCore(model).hear_along(speech[:320])


def test_agents_of_a_process_share_one_model(tmp_path):
    """``agent_core`` loads a shipped name or a model file once per process (the agents share its
    libraries, and the engine's one product per library); a file that changed is loaded again; a
    loaded model is used as given."""
    import os
    import shutil

    from headmotion.live.hold import agent_core, shared_model
    from headmotion.shipped import resolve_model_path

    a, b = agent_core("stream", settle_s=0.5, seed=0), agent_core("stream", settle_s=0.5, seed=1, lookahead_ms=200)
    assert a.model is b.model is shared_model("stream")
    path = tmp_path / "mine.hm"
    shutil.copy(resolve_model_path("stream"), path)
    first = shared_model(path)
    assert shared_model(str(path)) is first and first is not a.model
    os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 10**9))  # the file changed
    assert shared_model(path) is not first
    own = load_model("stream")
    assert agent_core(own, settle_s=0.5).model is own
