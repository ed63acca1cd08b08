"""``headmotion stream --hear SOURCE``: the other party's audio as a second input of the live
stream.  On a conversation of real speech (two voices, alternating turns; the heard side at another
rate and longer than the speech) the streamed frames equal ``headmotion synth SPEECH --hear OTHER``'s
— with the heard audio from a file, from raw PCM on stdin and from a named pipe — and differ from
the frames of the speech alone; the options' errors are one line."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

from headmotion.types import Audio

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]
SPEECH = ROOT / "examples" / "speech"
pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def conversation(tmp_path_factory):
    """(speech.wav at 16 kHz, other.wav at 44.1 kHz, other as s16le PCM): the head's side speaks
    for 3.5 s, is silent for 4 s while the other speaks, speaks 2 s more; the other's turn then
    runs on for 1.5 s after the speech has ended."""
    import soundfile as sf
    import soxr

    a, sr = sf.read(SPEECH / "speech_female.wav", dtype="float32")
    b, _ = sf.read(SPEECH / "speech_male.wav", dtype="float32")
    sec = lambda s: int(s * sr)  # noqa: E731
    speech = np.concatenate([a[:sec(3.5)], np.zeros(sec(4.0), np.float32), a[sec(3.5):sec(5.5)]])
    other = np.concatenate([np.zeros(sec(3.5), np.float32), b[:sec(4.0)], np.zeros(sec(2.0), np.float32),
                            b[sec(4.0):sec(5.5)]])
    other44 = np.clip(soxr.resample(other, sr, 44100), -1, 1).astype(np.float32)
    d = tmp_path_factory.mktemp("conversation")
    sf.write(d / "speech.wav", speech, sr, subtype="FLOAT")
    sf.write(d / "other.wav", other44, 44100, subtype="FLOAT")
    pcm = np.round(other44 * 32767).astype("<i2")
    (d / "other.s16le").write_bytes(pcm.tobytes())
    return d, pcm


@pytest.fixture(scope="module")
def model():
    from headmotion.synthesis import load_model

    return load_model("stream")


def _streamed(model, d, hear, **kw) -> np.ndarray:
    from headmotion.live.session import stream_live

    out = io.StringIO()
    stats = stream_live(model, input=str(d / "speech.wav"), hear=hear, json_stream=out, on_message=lambda _m: None,
                        **kw)
    recs = [json.loads(ln) for ln in out.getvalue().splitlines()]
    assert [r["frame"] for r in recs] == list(range(len(recs))) and stats["frames"] == len(recs)
    return np.array([r["rotvec"] for r in recs])


def _synth(model, d, other: Audio, listening: float = 1.0) -> np.ndarray:
    """``headmotion synth speech.wav --hear OTHER``, as the JSON lines round it."""
    import headmotion

    (m,) = headmotion.synthesize(str(d / "speech.wav"), model=model, hear=other, listening=listening)
    return np.round(m.rotvec, 6)


def test_a_heard_file_gives_synths_frames(conversation, model):
    from headmotion.io import load_audio

    d, _ = conversation
    got = _streamed(model, d, str(d / "other.wav"))
    ref = _synth(model, d, load_audio(d / "other.wav"))
    assert got.shape == ref.shape and len(ref) == round(11.0 * model.frame_rate)  # as long as the heard side
    np.testing.assert_array_equal(got, ref)
    alone = _streamed(model, d, None)
    assert len(alone) == round(9.5 * model.frame_rate)
    moved = np.degrees(np.abs(got[:len(alone)] - alone)).max(axis=1)
    turn = slice(int(4.0 * model.frame_rate), int(7.5 * model.frame_rate))  # the other's turn: the head listens
    assert moved[turn].max() > 1.0 and moved[:int(3.4 * model.frame_rate)].max() == 0.0
    quiet = _streamed(model, d, str(d / "other.wav"), controls=_controls(listening=0))
    np.testing.assert_array_equal(quiet, _synth(model, d, load_audio(d / "other.wav"), listening=0))


def _controls(**kw):
    from headmotion.synthesis import Controls

    return Controls.parse(**kw)


def test_heard_pcm_on_stdin_and_on_a_named_pipe(conversation, model, tmp_path):
    d, pcm = conversation
    ref = _synth(model, d, Audio(pcm.astype(np.float32) / 32768.0, 44100))
    got = _streamed(model, d, "-", hear_rate=44100, stdin=io.BytesIO(pcm.tobytes()))
    np.testing.assert_array_equal(got, ref)

    fifo = tmp_path / "other.pipe"
    os.mkfifo(fifo)

    def write():
        with open(fifo, "wb") as f:
            for i in range(0, len(pcm), 441):  # 10 ms writes, as a live writer makes them
                f.write(pcm[i:i + 441].tobytes())

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    got = _streamed(model, d, str(fifo), hear_rate=44100)
    writer.join(timeout=10)
    np.testing.assert_array_equal(got, ref)


def test_the_command_line(conversation, model):
    """``headmotion stream --input SPEECH --hear - --hear-rate 44100 --listening 2`` in a fresh process."""
    d, pcm = conversation
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run([sys.executable, "-m", "headmotion", "stream", "--input", str(d / "speech.wav"), "--hear", "-",
                        "--hear-rate", "44100", "--listening", "2"], input=pcm.tobytes(), capture_output=True,
                       timeout=120, env=env)
    assert r.returncode == 0, r.stderr.decode()
    got = np.array([json.loads(ln)["rotvec"] for ln in r.stdout.decode().splitlines()])
    np.testing.assert_array_equal(got, _synth(model, d, Audio(pcm.astype(np.float32) / 32768.0, 44100), listening=2))
    assert "hearing <stdin>" in r.stderr.decode()

    for args, needle in ((["--input", "-", "--hear", "-"], "--hear - and --input -: the speech and the heard audio "
                                                          "need two inputs"),
                         (["--input", str(d / "speech.wav"), "--hear", "-", "--hear-rate", "5"],
                          "--hear-rate must be between 1000 and 192000 Hz; got 5"),
                         (["--input", str(d / "speech.wav"), "--hear", str(d / "missing.wav")], "missing.wav")):
        r = subprocess.run([sys.executable, "-m", "headmotion", "stream", *args], input=b"", capture_output=True,
                           timeout=120, env=env)
        err = [ln for ln in r.stderr.decode().splitlines() if ln.strip()]
        assert r.returncode != 0 and len(err) == 1 and needle in err[0], (r.returncode, err)
        assert "Traceback" not in r.stderr.decode()
