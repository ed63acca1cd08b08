"""The post-processing chain (headmotion.motion.post): known answers for its stages in order,
chunking invariance, the one-frame path, and the tables' checks."""

import numpy as np
import pytest

from headmotion.motion.control import apply_gain_angles
from headmotion.motion.post import DNN_ORDER, LE2012_ORDER, TEMPLATE_ORDER, PostChain, PostTables
from headmotion.motion.post.range_limit import soft_range
from headmotion.motion.post.restore import CausalPost
from headmotion.motion.post.speed_shaping import product_shaper, speed_map
from headmotion.rotations import pitch_yaw_roll_to_rotvec

FPS = 100.0


def _walk(n=1500, seed=0):
    return 0.02 * np.random.default_rng(seed).standard_normal((n, 3)).cumsum(axis=0) / 10.0


def _tables(order, **kw):
    x = _walk(seed=5)
    base = dict(band_gains=np.full((4, 3), 1.3), speed_map=speed_map([x], [1.5 * x], lag=4),
                amplitude_gains=np.array([1.2, 0.8, 1.0]), amplitude_centre=np.zeros(3), idle=0.3,
                range_bounds=np.array([[0.05] * 3, [0.08] * 3]), range_centre=np.zeros(3),
                norm_mean=np.array([0.01, -0.02, 0.0]), norm_sd=np.array([2.0, 1.0, 0.5]))
    base.update(kw)
    return PostTables(fps=FPS, order=order, **base)


def _flags(n):
    f = np.ones(n, bool)
    f[300:700] = False
    return f


def test_template_chain_is_its_stages_in_order():
    """settle → amplify → shape → restore, each the primitive of its module on the same frames."""
    from headmotion.motion.pauses import CausalPauseWeight, PauseSettler

    t = _tables(TEMPLATE_ORDER)
    x, flags = _walk(), _flags(1500)
    y = PauseSettler(fps=FPS, idle=0.3).push(x, CausalPauseWeight(fps=FPS).push(flags))
    y = apply_gain_angles(y, np.zeros(3), t.amplitude_gains)
    y = product_shaper(t.speed_map, FPS).push(y)
    y = CausalPost(band_gains=t.band_gains, fps=FPS).push(y)
    np.testing.assert_array_equal(PostChain(t).push(x, flags), y)


def test_dnn_chain_denormalises_limits_and_skips_pauses_without_flags():
    t = _tables(DNN_ORDER, amplitude_gains=None, drift_share=0.0)
    x = _walk()
    y = CausalPost(band_gains=t.band_gains, fps=FPS).push(x) * t.norm_sd + t.norm_mean
    y = soft_range(product_shaper(t.speed_map, FPS).push(y), np.zeros(3), t.range_bounds)
    np.testing.assert_array_equal(PostChain(t).push(x), y)          # no flags: no settling
    assert np.abs(y).max() <= 0.08 + 1e-12
    assert not np.array_equal(PostChain(t).push(x, _flags(1500)), y)


def test_le2012_chain_turns_angles_into_rotation_vectors():
    t = _tables(LE2012_ORDER, idle=None, band_gains=None, speed_map=None)
    x = _walk()
    np.testing.assert_array_equal(PostChain(t).push(x), pitch_yaw_roll_to_rotvec(x[:, 0], x[:, 1], x[:, 2]))


@pytest.mark.parametrize("order", [DNN_ORDER, TEMPLATE_ORDER, LE2012_ORDER])
def test_chunks_and_single_frames_give_one_push(order):
    t = _tables(order, drift_share=0.3, drift_sd=np.full(3, 0.01))
    x, flags = _walk(), _flags(1500)
    whole = PostChain(t, seed=4).push(x, flags)
    c = PostChain(t, seed=4)
    parts = [c.push(x[a:min(a + 97, 1000)], flags[a:min(a + 97, 1000)]) for a in range(0, 1000, 97)]
    one = PostChain(t, seed=4)
    frames = [one.push_one(x[i], bool(flags[i])) for i in range(1000)]
    np.testing.assert_allclose(np.concatenate(parts), whole[:1000], rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.array(frames), whole[:1000], rtol=0, atol=1e-12)


def test_drift_is_seeded_and_tables_are_checked():
    t = _tables(DNN_ORDER, drift_share=0.3, drift_sd=np.full(3, 0.01))
    x = _walk()
    a, b = PostChain(t, seed=1).push(x), PostChain(t, seed=2).push(x)
    np.testing.assert_array_equal(a, PostChain(t, seed=1).push(x))
    assert np.abs(a - b).max() > 1e-4
    assert PostChain(PostTables(fps=FPS, order=DNN_ORDER)).identity
    assert t.only("shape", "restore").order == ("restore", "shape")
    with pytest.raises(ValueError, match="unknown post stages"):
        PostTables(fps=FPS, order=("restore", "wobble"))


def test_the_contract_fills_the_default_seed():
    """predict and stream without a seed use the model's ``seed`` parameter."""
    from headmotion.synthetic import planted_corpus
    from headmotion.systems import create

    corpus = planted_corpus(minutes=1.0, n_recordings=2, seed=0)
    m = create("tws-basic", n_init=1, seed=7).fit(corpus)
    audio = corpus[0].audio
    np.testing.assert_array_equal(m.predict(audio).rotvec, m.predict(audio, seed=7).rotvec)
    assert not np.array_equal(m.predict(audio).rotvec, m.predict(audio, seed=8).rotvec)
