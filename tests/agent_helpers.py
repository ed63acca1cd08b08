"""What the voice-agent integration tests share (tests/test_integration_pipecat.py and
test_integration_livekit.py, each run in its own environment): the speech they send, the stream's
own frames for it, the messages split into utterances, and the settling check."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from headmotion.io.resampler import Resampler
from headmotion.synthesis import load_model

SPEECH = Path(__file__).resolve().parents[1] / "examples" / "speech" / "short.wav"
FPS = 25.0
TOL = 1e-6  # the messages carry rotation vectors to 6 decimals


def speech_pcm(rate: int = 16000) -> np.ndarray:
    """short.wav as int16 at ``rate`` (resampled offline with soxr when not 16 kHz)."""
    x, sr = sf.read(SPEECH, dtype="float32")
    if rate != sr:
        import soxr

        x = soxr.resample(x, sr, rate, quality="HQ").astype(np.float32)
    return np.clip(np.round(x * 32767), -32768, 32767).astype(np.int16)


def reference(pcm: np.ndarray, rate: int, chunk_s: float = 0.05, flush: bool = True,
              lookahead_ms: float = 0.0) -> np.ndarray:
    """What ``load_model("stream").stream()`` gives for the same samples pushed directly (resampled
    to the model's rate as the integrations' default ``exact`` does), reading ``lookahead_ms`` ahead."""
    import copy

    model = copy.copy(load_model("stream")).set_params(lookahead_ms=lookahead_ms)
    stream = model.stream(seed=0)
    resample = Resampler(rate, int(model.sample_rate), quality="HQ")
    x = pcm.astype(np.float32) / np.float32(32768.0)
    n = int(rate * chunk_s)
    out = [np.asarray(stream.push(resample(x[i:i + n])).rotvec).reshape(-1, 3) for i in range(0, len(x), n)]
    if flush:
        out.append(np.asarray(stream.push(resample(np.zeros(0, np.float32), last=True)).rotvec).reshape(-1, 3))
        out.append(np.asarray(stream.flush().rotvec).reshape(-1, 3))
    return np.vstack(out)


def utterances(messages: list[dict], *, angles: bool = False) -> list[dict]:
    """Per utterance: its frames (numbers, rotvecs) and its end message (``angles``: every frame
    also carries its pitch, yaw and roll)."""
    out, cur = [], {"numbers": [], "rotvec": []}
    for m in messages:
        if m["type"] == "audio-start":  # marks where an utterance's audio begins
            continue
        if m["type"] == "frames":
            assert m["fps"] == FPS
            for f in m["frames"]:
                cur["numbers"].append(f["frame"])
                cur["rotvec"].append(f["rotvec"])
                assert f["time"] == pytest.approx(f["frame"] / FPS, abs=1e-4)
                if angles:
                    assert len(f["pitch_yaw_roll_deg"]) == 3
        else:
            assert m["type"] == "end"
            cur["end"] = m
            cur["rotvec"] = np.asarray(cur["rotvec"], dtype=np.float64).reshape(-1, 3)
            out.append(cur)
            cur = {"numbers": [], "rotvec": []}
    assert not cur["numbers"], "frames after the last end message"
    return out


def check_settling(before: np.ndarray, settle: np.ndarray, n_settle: int) -> None:
    """The settling starts where the head was, eases to the rest pose (0, 0, 0) and never jumps."""
    assert len(settle) == n_settle
    np.testing.assert_allclose(settle[-1], 0.0, atol=TOL)
    steps = np.linalg.norm(np.diff(np.vstack([before[-1:], settle]), axis=0), axis=1)
    last_step = np.linalg.norm(before[-1] - before[-2]) if len(before) > 1 else 0.0
    assert steps.max() <= 1.5 * np.linalg.norm(before[-1]) / n_settle + last_step + 2 * TOL  # settle_path's bound
    assert steps.max() < np.radians(2.0)


def check_decided_together(together: list, alone: list, sent: list[list[dict]], sent_alone: list[list[dict]]) -> None:
    """Agents run in one event loop with the default engine (``together``) and with
    ``engine=False`` (``alone``): the first shared one engine, whose ticks held decisions of
    several, the second had none, and each agent sent the same frames and end messages either
    way (grouped into messages as its sender found them due)."""
    engine = together[0].engine.engine
    assert engine is not None and all(a.engine.engine is engine for a in together)
    assert all(a.engine.engine is None for a in alone)
    assert engine.stats.largest >= 2  # decisions of several agents answered in one tick
    for msgs, msgs_alone in zip(sent, sent_alone):
        got, want = utterances(msgs), utterances(msgs_alone)
        assert [u["numbers"] for u in got] == [u["numbers"] for u in want]
        assert [u["end"] for u in got] == [u["end"] for u in want]
        for u, v in zip(got, want):
            np.testing.assert_array_equal(u["rotvec"], v["rotvec"])
