"""The listening ruler (``headmotion evaluate-listening``) can fail: known answers for the nods read
from a motion, the cues Praat reads, and the hits against shifted nods — nods planted at the cues
pass, nods at random times and a head that adds nothing fail."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.evaluation.measures.backchannel import Trial, follow_test, hit_share, motion_nods, praat_cues
from headmotion.types import Audio, Motion

FPS = 25.0
SR = 16000
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def pitch_motion(pitch_deg: np.ndarray) -> Motion:
    return Motion.from_euler(np.stack([np.zeros_like(pitch_deg), pitch_deg, np.zeros_like(pitch_deg)], axis=1),
                             "YXZ", FPS, degrees=True)


def bumps(times, depth=3.0, width_s=0.4, seconds=60.0):
    p = np.zeros(int(seconds * FPS))
    n = int(width_s * FPS)
    shape = depth * 0.5 * (1 - np.cos(2 * np.pi * np.arange(n) / (n - 1)))
    for t in times:
        a = int(round(t * FPS))
        p[a:a + n] += shape[:max(0, min(n, len(p) - a))]
    return p


def test_nods_are_pitch_peaks_of_two_degrees_and_a_human_width():
    m = pitch_motion(bumps([5.0, 20.0]))
    assert motion_nods(m, [(0.0, 60.0)]) == pytest.approx([5.2, 20.2], abs=0.05)
    assert motion_nods(m, [(10.0, 30.0)]) == pytest.approx([20.2], abs=0.05)     # only in the other's turns
    assert len(motion_nods(pitch_motion(bumps([5.0], depth=1.5)), [(0, 60)])) == 0  # too shallow
    assert len(motion_nods(pitch_motion(bumps([5.0], depth=-3.0)), [(0, 60)])) == 0  # nose up: no nod
    assert len(motion_nods(pitch_motion(bumps([5.0], width_s=3.0, depth=4.0)), [(0, 60)])) == 0  # too slow
    assert motion_nods(pitch_motion(bumps([5.0], depth=1.5)), [(0, 60)]).shape == (0,)


def test_the_hits_come_after_the_cue_in_their_window():
    cues = np.array([10.0, 20.0])
    assert hit_share([10.2, 10.4, 11.4, 11.6, 30.0], cues) == pytest.approx(2 / 5)
    assert np.isnan(hit_share([], cues)) and hit_share([5.0], []) == 0.0


def test_planted_nods_pass_and_random_or_no_nods_fail():
    rng = np.random.default_rng(3)
    spans = [(a, a + 8.0) for a in np.arange(0.0, 120.0, 12.0)]           # ten turns of 8 s
    cues = np.concatenate([a + np.sort(rng.uniform(0.5, 6.5, 3)) for a, _ in spans])
    led = [cues + 0.9 + rng.normal(0, 0.1, len(cues)) for _ in range(3)]
    res = follow_test([Trial(led, cues, spans)], shifts=500)
    assert max(res.p) < 0.05 and res.pooled_p < 0.01 and min(res.share) > 0.9
    random = [np.sort(np.concatenate([rng.uniform(a, b, 3) for a, b in spans])) for _ in range(3)]
    res = follow_test([Trial(random, cues, spans)], shifts=500)
    assert res.pooled_p > 0.05 and abs(res.pooled_share - res.pooled_shifted) < 0.15
    res = follow_test([Trial([np.zeros(0)] * 3, cues, spans)], shifts=50)
    assert res.nods == [0, 0, 0] and np.isnan(res.pooled_p)
    with pytest.raises(ParameterError, match="spans"):
        follow_test([Trial([cues], cues, [(5.0, 5.0)])])


def harmonic(f0: np.ndarray, sr: int = SR) -> np.ndarray:
    """A voiced sound with the pitch contour ``f0`` (Hz per sample): ten harmonics."""
    phase = 2 * np.pi * np.cumsum(f0) / sr
    return (0.1 * sum(np.sin(k * phase) / k for k in range(1, 11))).astype(np.float32)


def test_praat_reads_a_low_region_after_speech_as_a_cue():
    # 2 s of a voice at 200 Hz with a 5 Hz vibrato (below its 26th percentile for 50 ms at a time),
    # 0.3 s at 110 Hz, 1 s more
    t = np.arange(int(2.0 * SR)) / SR
    f = np.concatenate([200 + 8 * np.sin(2 * np.pi * 5 * t), np.full(int(0.3 * SR), 110.0),
                        200 + 8 * np.sin(2 * np.pi * 5 * t[:SR])])
    x = np.concatenate([np.zeros(SR // 2, np.float32), harmonic(f)])
    cues = praat_cues(Audio(x, SR), [(0.5, 0.5 + len(f) / SR)])
    assert len(cues) == 1 and abs(cues[0] - 2.5) < 0.06
    assert len(praat_cues(Audio(x, SR), [(0.5, 2.3)])) == 0              # the turn ends before the region


def test_conversations_put_the_other_party_in_its_turns():
    from headmotion.evaluation.protocol.conversations import arrange

    own = [np.ones(SR, np.float32)] * 2
    heard = [np.full(2 * SR, 0.5, np.float32)] * 4
    a, b, spans = arrange(own, heard, seed=0)
    assert len(a) == len(b) and len(spans) == 4
    for s, e in spans:
        i, j = int(s * SR), int(e * SR)
        assert np.all(b[i:j] == 0.5) and np.all(a[i:j] == 0.0)
    assert np.all(a * b == 0)                                              # one voice at a time


@pytest.mark.skipif(not (SHARED / "speech").is_dir(), reason="needs ../shared/data/speech (the shared data)")
def test_on_real_speech_the_listening_head_follows_the_cues_and_the_still_head_does_not():
    from headmotion.evaluation.protocol.conversations import build_conversations
    from headmotion.evaluation.protocol.listening import group_rows, run_conversation

    convs, _ = build_conversations("report", corpus=None, shared=SHARED, conditions=("clean",))
    one = [c for c in convs if c.voices == "one voice"]
    rows = {r.head: r for r in group_rows([run_conversation(c, "stream", seeds=[1]) for c in one], shifts=300)}
    assert rows["listening"].result.pooled_p < 0.05 and rows["cue-led nods"].result.pooled_p < 0.05
    assert rows["not listening"].result.pooled_p > 0.05
    assert 2 <= rows["listening"].nods_per_min <= 25


def test_the_command_refuses_bad_input_in_one_line(tmp_path, capsys):
    from headmotion.cli import main

    for args, needle in ((["--set", "nope"], "unknown set of conversations 'nope'"),
                         (["--corpus", str(tmp_path / "missing")], "--corpus must be a folder"),
                         (["--degrade", "clean,loud"], "unknown degradation 'loud'"),
                         (["--listening", "5"], "listening (--listening) must be a number from 0 to 3")):
        code = main(["evaluate-listening", "-o", str(tmp_path / "out"), *args])
        err = capsys.readouterr().err
        assert code != 0 and needle in " ".join(err.split()), (args, err)
        assert "Traceback" not in err and not (tmp_path / "out").exists()
