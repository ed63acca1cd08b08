"""Speaking mask (paper §4.2): detector and user annotations."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import FormatError, LengthMismatchError
from headmotion.features.vad import load_speaking_annotation, speaking_mask
from headmotion.io.audio import load_audio
from headmotion.types import Audio

SR = 16000


def _signal(parts, rng):
    """Concatenate (kind, seconds) parts: 'sil' (faint noise), 'tone' (150 Hz), 'noise' (loud white)."""
    out = []
    for kind, dur in parts:
        n = int(dur * SR)
        t = np.arange(n) / SR
        x = 1e-4 * rng.standard_normal(n)
        if kind == "tone":
            x += 0.3 * np.sin(2 * np.pi * 150 * t)
        elif kind == "noise":
            x += 0.3 * rng.standard_normal(n)
        out.append(x)
    return Audio(np.concatenate(out).astype(np.float32), SR)


def test_silence_tone_silence(rng):
    a = _signal([("sil", 1.0), ("tone", 1.0), ("sil", 1.0)], rng)
    m = speaking_mask(a, fps=100)
    assert m.dtype == bool and m.shape == (300,)
    on = np.flatnonzero(m)
    # the tone covers frames 100..199; hangover adds 50 ms (5 frames) on each side
    assert 94 <= on[0] <= 100 and 199 <= on[-1] <= 206
    assert m[100:200].all() and not m[:90].any() and not m[210:].any()
    m25 = speaking_mask(a, fps=25, n_frames=80)
    assert m25.shape == (80,) and m25[26:49].all() and not m25[:22].any()


def test_pauses_are_bridged_and_unvoiced_noise_rejected(rng):
    a = _signal([("sil", 0.5), ("tone", 0.5), ("sil", 0.2), ("tone", 0.5), ("sil", 1.0),
                 ("noise", 0.3), ("sil", 0.5)], rng)
    m = speaking_mask(a, fps=100)
    assert m[50:170].all()  # the 0.2 s pause inside the "utterance" counts as speaking
    assert not m[230:].any()  # the noise burst has no voicing
    m_nov = speaking_mask(a, fps=100, use_voicing=False)
    assert m_nov[270:290].all()


def test_constant_signals():
    assert not speaking_mask(Audio(np.zeros(SR, np.float32), SR), fps=100).any()
    t = np.arange(SR) / SR
    loud = Audio((0.3 * np.sin(2 * np.pi * 200 * t)).astype(np.float32), SR)
    assert speaking_mask(loud, fps=100).all()
    assert speaking_mask(Audio(np.zeros(0, np.float32), SR), fps=100).shape == (0,)


def test_real_speech(examples_dir):
    a = load_audio(examples_dir / "speech" / "speech_male.wav")
    m = speaking_mask(a, fps=100)
    assert 0.7 < m.mean() < 0.97
    # the file starts and ends with 0.4 s of silence
    assert not m[:30].any() and not m[-30:].any()


@pytest.mark.shared
def test_real_speech_shared(shared_data):
    a = load_audio(shared_data / "speech" / "jfk.flac", sample_rate=16000)
    m = speaking_mask(a, fps=100)
    assert 0.55 < m.mean() < 0.95
    # JFK pauses between phrases: there are several silent stretches of at least 0.3 s
    runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[1], m.astype(int), [1]])) != 0))[::2]
    assert sum(r >= 30 for r in runs) >= 2


# --------------------------------------------------------------------------- annotations

def test_per_frame_annotations(tmp_path):
    flags = np.r_[np.zeros(10), np.ones(20), np.zeros(10)].astype(int)
    np.save(tmp_path / "m.npy", flags)
    m = load_speaking_annotation(tmp_path / "m.npy", fps=100, n_frames=40)
    np.testing.assert_array_equal(m, flags.astype(bool))
    (tmp_path / "m.csv").write_text("speaking\n" + "\n".join(map(str, flags)) + "\n")
    np.testing.assert_array_equal(load_speaking_annotation(tmp_path / "m.csv", fps=100, n_frames=41),
                                  np.r_[flags, 0].astype(bool))  # one frame short: padded
    with pytest.raises(LengthMismatchError, match="40 frames but 60"):
        load_speaking_annotation(tmp_path / "m.npy", fps=100, n_frames=60)
    (tmp_path / "bad.csv").write_text("0\n1\n2\n")
    with pytest.raises(FormatError, match="line 3"):
        load_speaking_annotation(tmp_path / "bad.csv", fps=100, n_frames=3)


def test_audacity_interval_labels(tmp_path):
    p = tmp_path / "labels.txt"
    p.write_text("0.500000\t1.200000\tspeech\n"
                 "\\\t300.0\t3000.0\n"          # Audacity spectral-selection line: skipped
                 "1.200000\t1.500000\tsil\n"
                 "2.0 2.25\n")
    m = load_speaking_annotation(p, fps=100, n_frames=300)
    expected = np.zeros(300, bool)
    expected[50:120] = True
    expected[200:225] = True
    np.testing.assert_array_equal(m, expected)
    (tmp_path / "bad.txt").write_text("0.5\t1.0\n2.0\tabc\n")
    with pytest.raises(FormatError, match="line 2"):
        load_speaking_annotation(tmp_path / "bad.txt", fps=100, n_frames=300)
    (tmp_path / "rev.txt").write_text("2.0 1.0 x\n")
    with pytest.raises(FormatError, match="not valid"):
        load_speaking_annotation(tmp_path / "rev.txt", fps=100, n_frames=300)
    with pytest.raises(FormatError, match="not found"):
        load_speaking_annotation(tmp_path / "none.txt", fps=100, n_frames=3)
