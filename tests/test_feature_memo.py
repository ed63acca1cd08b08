"""The process's recent feature extractions (headmotion.features.memo): the same samples are not
analysed twice, a changed sample is, the kept track is read-only, and the kept bytes are bounded."""

from __future__ import annotations

import numpy as np
import pytest

import headmotion.features as F
from headmotion.features import memo
from headmotion.types import Audio


@pytest.fixture(autouse=True)
def empty_memo():
    memo.clear()
    yield
    memo.clear()


@pytest.fixture
def counted(monkeypatch):
    calls = []
    real = F.extract

    def spy(name, audio, **kw):
        calls.append(name)
        return real(name, audio, **kw)

    monkeypatch.setattr(F, "extract", spy)
    return calls


def tone(seconds=1.0, hz=150.0, sr=16000):
    t = np.arange(int(seconds * sr)) / sr
    return Audio((0.3 * np.sin(2 * np.pi * hz * t)).astype(np.float32), sr)


def test_the_same_samples_are_analysed_once_and_give_the_same_values(counted):
    cfg = F.FeatureConfig("f0e", fps=100)
    a = tone()
    first = cfg.extract(a)
    again = cfg.extract(Audio(a.samples.copy(), a.sample_rate))  # equal samples, another array
    assert counted == ["f0e"]
    np.testing.assert_array_equal(first.values, again.values)
    assert again.names == first.names and again.fps == first.fps
    cfg.extract(a, n_frames=50)  # another length is another extraction
    F.FeatureConfig("f0e", fps=50).extract(a)  # and another configuration
    assert counted == ["f0e"] * 3


def test_a_changed_sample_is_analysed_again(counted):
    cfg = F.FeatureConfig("mfcc", fps=100)
    a = tone()
    cfg.extract(a)
    b = a.samples.copy()
    b[123] += 0.01
    cfg.extract(Audio(b, a.sample_rate))
    assert counted == ["mfcc", "mfcc"]


def test_the_kept_track_cannot_be_written(counted):
    cfg = F.FeatureConfig("mfcc", fps=100)
    a = tone()
    first = cfg.extract(a)
    with pytest.raises(ValueError):
        first.values[:] = 0.0  # a FeatureTrack's values are read-only: the one kept track is shared
    assert cfg.extract(a) is first and counted == ["mfcc"]


def test_registered_extractors_are_always_called(counted):
    n = []

    def mine(audio, *, fps, n_frames):
        n.append(1)
        return np.full((n_frames, 1), float(len(n)))

    F.register("memo_test_counter", mine, overwrite=True)
    try:
        cfg = F.FeatureConfig("memo_test_counter", fps=100)
        a = tone()
        assert cfg.extract(a).values[0, 0] == 1.0 and cfg.extract(a).values[0, 0] == 2.0
    finally:
        F.unregister("memo_test_counter")


def test_the_kept_bytes_are_bounded(monkeypatch, counted):
    cfg = F.FeatureConfig("mfcc", fps=100)
    one = cfg.extract(tone(hz=100.0)).values.nbytes
    memo.clear()
    counted.clear()
    monkeypatch.setattr(memo, "MAX_BYTES", 2 * one)
    tones = [tone(hz=h) for h in (100.0, 200.0, 300.0)]
    for t in tones:
        cfg.extract(t)
    cfg.extract(tones[2])
    cfg.extract(tones[1])  # the two most recent are kept
    assert len(counted) == 3
    cfg.extract(tones[0])  # the least recently used was dropped
    assert len(counted) == 4
