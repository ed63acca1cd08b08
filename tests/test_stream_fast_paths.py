"""The one-frame paths of the causal streams (compute per 10 ms chunk) give what the
batch code gives: the same operations on scalars or 1-D rows, so the same bits (the closed-form
rotation: scipy's to 1e-12 rad).  Whole streams equal offline synthesis in test_stream_causal.py."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from headmotion.features.streaming import StreamingF0e, yin_frames, yin_row
from headmotion.motion.pauses import CausalPauseWeight, PauseSettler
from headmotion.rotations import pitch_yaw_roll_to_rotvec, pitch_yaw_roll_to_rotvec_one
from headmotion.features.speech_activity import SpeechDetector

FPS = 100.0


def _windows(rng):
    """YIN windows (win 400 + tau_max 214 at 16 kHz): harmonic tones, noise, silence, a tone
    starting half-way, a near-silent one."""
    ex = StreamingF0e()
    n, t = ex.f0_len, np.arange(ex.f0_len) / 16000
    rows = [sum(np.sin(2 * np.pi * k * f0 * t) / k for k in range(1, 5)) for f0 in (80, 123.4, 150, 210, 390)]
    rows += [rng.standard_normal(n), np.zeros(n), np.r_[np.zeros(n // 2), np.sin(2 * np.pi * 140 * t[: n - n // 2])],
             1e-9 * rng.standard_normal(n)]
    return ex, np.array(rows)


def test_yin_row_equals_yin_frames_bit_for_bit(rng):
    ex, X = _windows(rng)
    period, ap = yin_frames(X, ex.win, ex.tau_min, ex.tau_max, ex.threshold)
    for k, x in enumerate(X):
        assert yin_row(x, ex.win, ex.tau_min, ex.tau_max, ex.threshold) == (period[k], ap[k]), k
    # a 150 Hz tone: the known period
    assert yin_row(X[2], ex.win, ex.tau_min, ex.tau_max, ex.threshold)[0] == pytest.approx(16000 / 150, rel=1e-3)
    assert yin_row(X[6], ex.win, ex.tau_min, ex.tau_max, ex.threshold) == (0.0, 1.0)  # silence


def test_features_pushed_a_frame_at_a_time_equal_the_whole_file(rng):
    t = np.arange(3 * 16000) / 16000
    f0 = 120 + 40 * np.sin(2 * np.pi * 0.7 * t)
    x = np.sin(2 * np.pi * np.cumsum(f0) / 16000) * (np.sin(2 * np.pi * 1.3 * t) > -0.3)
    x = (0.3 * x + 0.01 * rng.standard_normal(len(t))).astype(np.float32)
    for voicing in (False, True):
        ex = StreamingF0e(voicing=voicing)
        whole = np.vstack([ex.push(x), ex.flush()])
        ex = StreamingF0e(voicing=voicing)
        parts = [ex.push(x[i:i + 160]) for i in range(0, len(x), 160)] + [ex.flush()]
        assert np.array_equal(np.vstack(parts), whole)
        assert whole[:, 0].std() > 0.05  # the pitch moves


def test_causal_weight_one_frame_equals_the_vectorised_push(rng):
    flags = rng.random(3000) < 0.6
    flags[500:900] = False
    flags[1500:1504] = True          # a blip shorter than min_speech
    for kw in ({}, {"delay_s": 0.0, "full_s": 0.17, "release_s": 0.0}):
        whole = CausalPauseWeight(fps=FPS, **kw).push(flags)
        one = CausalPauseWeight(fps=FPS, **kw)
        got = np.array([one.push_one(bool(f)) for f in flags])
        assert np.array_equal(got, whole)
        assert whole.max() == pytest.approx(1.0) and whole.min() == 0.0
    # mixed: one-frame and vectorised pushes on the same state
    mixed, i = CausalPauseWeight(fps=FPS), 0
    parts = []
    while i < len(flags):
        n = int(rng.integers(1, 4))
        parts.append(mixed.push(flags[i:i + n]) if n > 1 else np.array([mixed.push_one(bool(flags[i]))]))
        i += n
    assert np.array_equal(np.concatenate(parts), CausalPauseWeight(fps=FPS).push(flags))


@pytest.mark.parametrize("pull", [0.0, 0.5])
def test_settler_one_frame_equals_one_frame_pushes(rng, pull):
    x = np.cumsum(0.01 * rng.standard_normal((1500, 3)), axis=0)
    w = CausalPauseWeight(fps=FPS).push(rng.random(1500) < 0.5)
    kw = dict(fps=FPS, idle=0.3, pull=pull, mean_pose=np.zeros(3))
    a, b = PauseSettler(**kw), PauseSettler(**kw)
    one = np.array([a.push_one(x[t].tolist(), float(w[t])) for t in range(len(x))])
    ref = np.vstack([b.push(x[t:t + 1], w[t:t + 1]) for t in range(len(x))])
    assert np.array_equal(one, ref)
    # and the whole utterance at once (closed-form blocks: rounding only)
    np.testing.assert_allclose(one, PauseSettler(**kw).push(x, w), rtol=0, atol=1e-12)
    assert np.abs(one - x).max() > 1e-3  # it settles


def test_speech_tracker_one_frame_equals_push_db(rng):
    det = SpeechDetector(col=0, mu=0.0, sd=1.0, db_per_unit=1.0, fps=FPS)
    e = np.where(rng.random(1200) < 0.5, -30.0, -70.0) + rng.standard_normal(1200)
    e[400:700] = -75 + rng.standard_normal(300)        # a long pause
    whole = det.start().push_db(e)
    tr = det.start()
    got = [bool(tr.push_db(e[:5])[i]) for i in range(5)] + [tr.push_db(e[5:9])[i] for i in range(4)]
    got += [tr.push_one_db(float(v)) for v in e[9:]]
    assert np.array_equal(np.array(got, dtype=bool), whole)
    assert whole[:400].mean() > 0.3 and whole[420:690].mean() < 0.05


def test_closed_form_euler_equals_scipy(rng):
    angles = [rng.uniform(-s, s, (4000, 3)) for s in (1e-7, 1e-4, 1e-3, 0.05, 0.5, 1.5, 3.1)]
    special = np.array([[0, 0, 0], [np.pi / 2, 0.3, -0.2], [-np.pi / 2, 1.0, 1.0], [0, np.pi, 0],
                        [0.1, -np.pi, 0.2], [1e-3, 0, 0], [0, 0, 2 * np.pi - 1e-9]])
    A = np.vstack(angles + [special])
    ref = pitch_yaw_roll_to_rotvec(A[:, 0], A[:, 1], A[:, 2])
    got = np.array([pitch_yaw_roll_to_rotvec_one(*a) for a in A])
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    assert pitch_yaw_roll_to_rotvec_one(0.2, 0.0, 0.0) == pytest.approx([0.2, 0.0, 0.0], abs=1e-15)


@pytest.fixture(scope="module")
def planted():
    from headmotion.synthetic import planted_corpus

    return planted_corpus(minutes=1.0, n_recordings=2, seed=4)


@pytest.mark.slow
@pytest.mark.parametrize("features", ["prosody-live", "f0e-live"])
@pytest.mark.parametrize("joint", [False, True])
def test_le2012_compiled_conditioning_equals_einsum(planted, features, joint):
    from headmotion.systems import create

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = create("le2012", features=features, joint=joint).fit(planted)
    F = np.asarray(m._config().extract(planted[0].audio, n_frames=300).values, dtype=np.float64)
    _, fast = m._cond_rows(F, pad=2)
    m.set_params(compiled=False)
    cond, slow = m._cond_rows(F, pad=2)
    assert cond is not None and fast[0] == slow[0]
    for a, b in zip(fast[1:], slow[1:]):
        assert a.shape == b.shape
        if features == "prosody-live":   # two features: sums of two products, the same bits
            assert np.array_equal(a, b)
        else:                            # six: another summation order, rounding only
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-12)
    assert np.all(fast[1][:2] == 0) and np.ptp(fast[1][2:]) > 0.1   # the padding rows, then data


@pytest.mark.slow
def test_tws_render_one_equals_render(planted):
    from headmotion.systems import create
    from headmotion.systems.tws.generator import Generator

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = create("tws-basic").fit(planted)
    audio = planted[0].audio
    T = 600
    gen = Generator(m, rng=np.random.default_rng(1), fps=m.fps_)
    gen.push_features(m._features_full(audio, T))
    gen.run()
    ref = gen.render(0, T)
    assert np.array_equal(np.array([gen.render_one(t) for t in range(T)]), ref)
    # settled, one frame at a time, against the batch (another generator, same seed)
    g2 = Generator(m, rng=np.random.default_rng(1), fps=m.fps_)
    g2.push_features(m._features_full(audio, T))
    g2.run()
    one = np.array([gen.render_settled_one(t) for t in range(T)])
    np.testing.assert_allclose(one, g2.render_settled(0, T), rtol=0, atol=1e-12)
    assert gen.detector is not None and np.abs(one - ref).max() > 0  # pauses were settled
