"""Evaluation anchors (thesis §4.2.4, §4.3.1)."""

import numpy as np
import pytest

from headmotion.corpus import Corpus
from headmotion.errors import NotFittedError, ParameterError
from headmotion.synthetic import planted_corpus
from headmotion.evaluation.protocol.anchors import ANCHORS, create_anchor, shaped_noise
from headmotion.systems import create


@pytest.fixture(scope="module")
def corpus():
    return planted_corpus(minutes=1.5, n_recordings=3, speakers=("a", "b"), seed=4)


def test_ground_truth_desync_other_still(corpus):
    rec = corpus[0]
    gt = create_anchor("ground-truth").fit(corpus).motion_for(rec)
    np.testing.assert_array_equal(gt.rotvec, rec.motion.rotvec)
    de = create_anchor("desync").fit(corpus).motion_for(rec, seed=0)
    assert len(de) == len(rec.motion) and not np.allclose(de.rotvec, rec.motion.rotvec)
    same = [r for r in corpus if r.speaker == rec.speaker and r.id != rec.id]
    assert any(np.allclose(de.rotvec[:100], r.motion.rotvec[:100]) for r in same)
    ot = create_anchor("other-speaker").fit(corpus).motion_for(rec, seed=0)
    others = [r for r in corpus if r.speaker != rec.speaker]
    assert any(np.allclose(ot.rotvec[:100], r.motion.rotvec[:100]) for r in others)
    st = create_anchor("still").fit(corpus)
    s = st.motion_for(rec)
    assert np.ptp(s.rotvec, axis=0).max() == 0
    np.testing.assert_allclose(s.rotvec[0], np.vstack([r.motion.rotvec for r in corpus]).mean(axis=0))


def test_shaped_noise_spectrum_and_smoothness(corpus):
    sn = create_anchor("shaped-noise").fit(corpus)
    rec = corpus[0]
    m = sn.motion_for(rec, seed=1)
    ref = np.vstack([r.motion.rotvec for r in corpus])
    np.testing.assert_allclose(m.rotvec.std(axis=0), ref.std(axis=0), rtol=1e-6)
    # low-pass like head motion: most power below 3 Hz
    P = np.abs(np.fft.rfft(m.rotvec - m.rotvec.mean(0), axis=0)) ** 2
    f = np.fft.rfftfreq(len(m), 1 / m.fps)
    assert P[f < 3].sum() / P.sum() > 0.8
    assert not np.allclose(m.rotvec, sn.motion_for(rec, seed=2).rotvec)
    np.testing.assert_array_equal(m.rotvec, sn.motion_for(rec, seed=1).rotvec)
    x = shaped_noise(0, np.ones((5, 3)), rng=np.random.default_rng(0), fps=100, sd=np.ones(3), mean=np.zeros(3))
    assert x.shape == (0, 3)


def test_floor_gives_other_speakers_heads_never_twice(corpus):
    """Known answer: every held-out recording gets a contiguous stretch of another speaker's recorded
    head, of its own length, and no frame of the training heads is given out twice."""
    train = corpus.filter(speaker="b")
    held = list(corpus.filter(speaker="a"))
    fl = create_anchor("floor", random_state=3).fit(train)
    src = {r.id: np.asarray(r.motion.rotvec) for r in train}
    used = {rid: np.zeros(len(x), bool) for rid, x in src.items()}
    for rec in held:
        m = fl.motion_for(rec, seed=0)
        assert len(m) == len(rec.motion) and m.fps == rec.motion.fps
        hits = [(rid, s) for rid, x in src.items() for s in range(len(x) - len(m) + 1)
                if np.array_equal(x[s], m.rotvec[0]) and np.array_equal(x[s:s + len(m)], m.rotvec)]
        assert len(hits) == 1
        rid, s = hits[0]
        assert not used[rid][s:s + len(m)].any()
        used[rid][s:s + len(m)] = True
        np.testing.assert_array_equal(fl.motion_for(rec).rotvec, m.rotvec)  # asked again: the same stretch
    # the same seed deals the same stretches; the held-out speaker's own heads never
    again = create_anchor("floor", random_state=3).fit(train)
    np.testing.assert_array_equal(again.motion_for(held[0]).rotvec, fl.motion_for(held[0]).rotvec)
    with pytest.raises(ParameterError, match="another speaker"):
        create_anchor("floor").fit(corpus.filter(speaker="a")).motion_for(held[0])


def test_anchor_errors(corpus):
    one_speaker = corpus.filter(speaker="a")
    with pytest.raises(ParameterError, match="another speaker"):
        create_anchor("other-speaker").fit(one_speaker).motion_for(one_speaker[0])
    with pytest.raises(ParameterError, match="at least one"):
        create_anchor("still").fit(Corpus([]))


def test_anchors_are_evaluation_conditions_not_systems(corpus):
    assert sorted(ANCHORS) == ["desync", "floor", "ground-truth", "other-speaker", "shaped-noise", "shifted", "still"]
    assert [n for n, c in ANCHORS.items() if c.needs_other_speakers] == ["other-speaker", "floor"]
    with pytest.raises(ParameterError, match="unknown system 'desync'"):
        create("desync")
    with pytest.raises(ParameterError, match="unknown anchor"):
        create_anchor("tws-hier")
    with pytest.raises(NotFittedError):
        create_anchor("still").motion_for(corpus[0])
