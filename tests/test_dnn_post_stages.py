"""Known answers for the DNN post stages that need no network: the causal
band split, the per-band gains, the speed map and the speed shaper."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.motion.post import speed_shaping
from headmotion.motion.post import restore as dnn_post

FPS = 100.0


def sine(f_hz: float, seconds: float = 60.0, amp: float = 1.0) -> np.ndarray:
    t = np.arange(int(seconds * FPS)) / FPS
    return amp * np.sin(2 * np.pi * f_hz * t)[:, None] * np.ones(3)


def test_band_split_sums_to_its_input_and_is_chunking_invariant():
    x = np.random.default_rng(0).standard_normal((1500, 3))
    whole = dnn_post.BandSplit(fps=FPS, dims=3).push(x)
    np.testing.assert_allclose(whole.sum(axis=1), x, atol=1e-12)
    split = dnn_post.BandSplit(fps=FPS, dims=3)
    parts = np.concatenate([split.push(x[a:b]) for a, b in ((0, 1), (1, 137), (137, 1500))])
    np.testing.assert_array_equal(parts, whole)


@pytest.mark.parametrize("f_hz, band, share", [(0.1, 0, 0.9), (0.7, 1, 0.55), (1.8, 2, 0.55), (7.0, 3, 0.9)])
def test_a_sinusoid_lands_mostly_in_its_band(f_hz, band, share):
    # causal complementary bands are soft (a low-pass's phase lag leaks into the rest): a
    # sinusoid inside a band puts most, not all, of its power there
    bands = dnn_post.BandSplit(fps=FPS, dims=3).push(sine(f_hz))[1000:]
    power = (bands ** 2).mean(axis=(0, 2))
    assert power.argmax() == band
    assert power[band] / power.sum() > share


def test_band_gains_of_a_scaled_copy_and_the_drift_reserve():
    rng = np.random.default_rng(1)
    pred = [rng.standard_normal((2000, 3)) for _ in range(3)]
    g = dnn_post.band_gains(pred, [2.0 * p + 3.0 for p in pred], fps=FPS)
    np.testing.assert_allclose(g, 2.0, rtol=1e-9)
    np.testing.assert_allclose(dnn_post.band_gains(pred, pred, fps=FPS), 1.0, rtol=1e-12)
    np.testing.assert_allclose(dnn_post.band_gains([1e-4 * p for p in pred], pred, fps=FPS), dnn_post.BAND_CAP)
    reserved = dnn_post.band_gains(pred, pred, fps=FPS, share=0.5)
    assert np.all(reserved[0] < 1.0) and np.allclose(reserved[1:], 1.0)


def test_causal_post_with_unit_band_gains_is_the_identity_about_the_running_mean():
    y = np.random.default_rng(2).standard_normal((800, 3)) + 4.0
    out = dnn_post.CausalPost(band_gains=np.ones((4, 3)), fps=FPS).push(y)
    np.testing.assert_allclose(out, y, atol=1e-12)


def test_speed_map_of_one_set_is_the_identity_and_speeds_over_a_lag():
    x = np.cumsum(np.random.default_rng(3).standard_normal((3000, 3)), axis=0)
    t = speed_shaping.speed_map([x], [x])
    np.testing.assert_allclose(t[0], t[1], atol=1e-9)
    fast = speed_shaping.speed_map([x], [3.0 * x], max_gain=None)
    np.testing.assert_allclose(fast[1], 3.0 * fast[0], rtol=1e-6)
    np.testing.assert_allclose(speed_shaping.speed_map([x], [3.0 * x])[1], speed_shaping.SPEED_MAX_GAIN * fast[0], rtol=1e-6)
    line = np.arange(10.0)[:, None] * np.array([[3.0, 4.0, 0.0]])  # speed 5 per frame
    np.testing.assert_allclose(speed_shaping.speeds(line, 4)[4:], 5.0)


def test_speed_shaper_identity_halving_and_chunking():
    x = sine(2.0, 20.0, amp=0.1)
    ident = np.stack([np.linspace(0, 1, 11)] * 2)
    np.testing.assert_allclose(speed_shaping.SpeedShaper(ident, fps=FPS).push(x), x, atol=1e-12)
    half = np.stack([np.linspace(0, 1, 11), 0.5 * np.linspace(0, 1, 11)])
    sh = speed_shaping.SpeedShaper(half, fps=FPS, follow_s=2.0, lag=4)
    out = sh.push(x)
    # every increment halved, a slow leak back onto the path: the 2 Hz swing is about half as large
    assert out[500:].std() / x[500:].std() == pytest.approx(0.5, abs=0.06)
    sh2 = speed_shaping.SpeedShaper(half, fps=FPS, follow_s=2.0, lag=4)
    parts = np.concatenate([sh2.push(x[a:b]) for a, b in ((0, 2), (2, 333), (333, len(x)))])
    np.testing.assert_array_equal(parts, out)


def test_speed_shaper_adaptation_takes_out_the_input_s_speed_scale():
    """An identity map measured on a sinusoid; fed the same sinusoid twice as fast (twice the
    amplitude), the adapting shaper's running liveliness ratio tends to 2 and the output moves at
    the map's speeds again (the sinusoid's own amplitude)."""
    x = sine(1.0, 60.0, amp=0.1)
    table = speed_shaping.speed_map([x], [x], lag=4)
    sh = speed_shaping.SpeedShaper(table, fps=FPS, follow_s=5.0, lag=4, adapt_s=1.0)
    out = sh.push(2.0 * x)
    late = slice(len(x) // 2, None)
    speed_in = speed_shaping.speeds(x, 4)[late].mean()
    assert speed_shaping.speeds(out, 4)[late].mean() / speed_in == pytest.approx(1.0, abs=0.1)
    assert sh.sum_sp / sh.n_sp / sh.ref_mean == pytest.approx(2.0, abs=0.05)
    # on an input at the map's own scale the adaptation changes nothing
    same = speed_shaping.SpeedShaper(table, fps=FPS, follow_s=5.0, lag=4, adapt_s=1.0).push(x)
    np.testing.assert_allclose(same[late], x[late], atol=0.02 * np.ptp(x))
    sh2 = speed_shaping.SpeedShaper(table, fps=FPS, follow_s=5.0, lag=4, adapt_s=1.0)
    parts = np.concatenate([sh2.push(2.0 * x[a:b]) for a, b in ((0, 3), (3, 777), (777, len(x)))])
    np.testing.assert_array_equal(parts, out)


def test_slow_band_gain_scales_the_slow_band_only():
    from types import SimpleNamespace

    from headmotion.errors import ParameterError
    from headmotion.systems import create
    from headmotion.motion.post import PostChain
    from headmotion.systems.dnn.synthesis import post_tables

    gains = np.full((4, 3), 2.0)
    system = SimpleNamespace(drift_share=0.0, seed=0, band_gains_=gains, variance_restore=True, restore_bands=True,
                             gv_=np.ones(3), motion_sd_=np.ones(3), model_fps=FPS, drift_tau_s=4.0,
                             slow_band_gain=1.5, idle=None, speed_shaping=False, range_limit=False,
                             motion_norm_=SimpleNamespace(mean_=np.zeros(3), std_=np.ones(3)))
    tables = post_tables(system).only("restore")
    np.testing.assert_allclose(tables.band_gains[0], 3.0)
    np.testing.assert_allclose(tables.band_gains[1:], 2.0)
    assert np.all(gains == 2.0)  # the model's own gains are left alone
    # a slow sinusoid about its mean comes out ≈ 1.5 × 2 larger, a fast one 2 ×
    for f_hz, factor in ((0.05, 3.0), (7.0, 2.0)):
        y = sine(f_hz, seconds=200.0)
        out = PostChain(tables, seed=0).push(y)[-4000:]
        assert out.std(axis=0) / y[-4000:].std(axis=0) == pytest.approx(np.full(3, factor), rel=0.08)
    for bad in (0, -1.0, "2", True, float("nan")):
        with pytest.raises(ParameterError, match="slow_band_gain"):
            create("mfcc-dnn", slow_band_gain=bad).fit(None)


def test_delivered_speed_map_makes_the_shaper_deliver_the_target_quantiles():
    """Known answer: a smooth random path, and as target a burstier one (its steps scaled by
    gamma-distributed factors: holds and quick moves).  The static quantile map asks for the
    target's speeds, but the causal shaper (leak back onto the path, liveliness adaptation)
    delivers 13–16 % too little at every quantile; two closed-loop corrections deliver the
    target's quantiles up to the 75th within 3 % (the top stays bounded by ``max_gain``), stay
    stable with more iterations, keep the map monotone, and 0 iterations is the static map."""
    from scipy.ndimage import gaussian_filter1d

    rng = np.random.default_rng(5)
    x = gaussian_filter1d(np.cumsum(rng.standard_normal((12000, 3)), axis=0), 8.0, axis=0) * 1e-3
    steps = rng.standard_normal((12000, 3)) * rng.gamma(0.5, 2.0, (12000, 1))
    y = gaussian_filter1d(np.cumsum(steps, axis=0), 8.0, axis=0) * 1e-3
    lag = speed_shaping.shaping_lag(FPS)
    levels = [0.1, 0.25, 0.5, 0.75]
    goal = np.quantile(speed_shaping.speeds(y, lag)[lag:], levels)

    def delivered(table):
        out = speed_shaping.product_shaper(table, FPS).push(x)
        return np.quantile(speed_shaping.speeds(out, lag)[lag:], levels) / goal

    static = speed_shaping.delivered_speed_map([x], [y], fps=FPS, lag=lag, iterations=0, max_gain=2.0)
    np.testing.assert_array_equal(static, speed_shaping.speed_map([x], [y], lag=lag, max_gain=2.0))
    assert np.all(delivered(static) < 0.92)
    loop = speed_shaping.delivered_speed_map([x], [y], fps=FPS, lag=lag, iterations=2, max_gain=2.0)
    np.testing.assert_allclose(delivered(loop), 1.0, atol=0.03)
    more = speed_shaping.delivered_speed_map([x], [y], fps=FPS, lag=lag, iterations=5, max_gain=2.0)
    np.testing.assert_allclose(delivered(more), 1.0, atol=0.03)
    assert np.all(np.diff(loop[1]) > 0) and np.all(loop[1] <= 2.0 * loop[0] + 1e-12)
