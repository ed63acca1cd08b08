"""The soft range limit (headmotion.motion.post.range_limit) and its use in the DNN systems."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.motion.post.range_limit import range_from_training, soft_range


def test_inside_the_knee_nothing_changes_and_outside_it_bends_towards_the_limit():
    bounds = np.array([[1.0, 2.0], [2.0, 3.0]])          # knee 1 / 2, asymptote 2 / 3 on the two axes
    x = np.array([[0.5, -1.9], [1.0, 2.0], [1.5, 2.5], [100.0, -100.0]]) + 10.0
    y = soft_range(x, [10.0, 10.0], bounds)
    np.testing.assert_array_equal(y[:2], x[:2])                     # at or inside the knee: unchanged
    np.testing.assert_allclose(y[2] - 10, [1 + np.tanh(0.5), 2 + np.tanh(0.5)])   # k + (L - k) tanh((|d| - k)/(L - k))
    np.testing.assert_allclose(y[3] - 10, [2.0, -3.0], atol=1e-12)  # far out: at the asymptote, sign kept
    # slope 1 at the knee (continuous velocity) and strictly inside the asymptote
    e = 1e-6
    d = soft_range(np.array([[1.0 + e, 0.0]]), [0.0, 0.0], bounds)[0, 0] - 1.0
    assert d == pytest.approx(e, rel=1e-5)
    t = np.linspace(-50, 50, 2001)[:, None].repeat(2, 1)
    assert np.all(np.abs(soft_range(t, [0, 0], bounds)) < bounds[1] + 1e-12)
    assert np.all(np.diff(soft_range(t, [0, 0], bounds), axis=0) >= 0)      # monotone


def test_bounds_from_training_are_its_99th_percentile_and_its_range_plus_a_tenth():
    rng = np.random.default_rng(0)
    m = [rng.uniform(-1, 1, size=(5000, 3)), rng.uniform(-1, 1, size=(5000, 3))]
    b = range_from_training(m, np.zeros(3))
    np.testing.assert_allclose(b[0], 0.99, atol=0.01)
    np.testing.assert_allclose(b[1], 1.1 * np.abs(np.vstack(m)).max(axis=0))


def test_the_default_model_applies_it_after_the_shaper_and_stays_in_range():
    """The former shipped default (mfcc-dnn, tests/data/models): with ``range_limit`` the post stages' output (no pauses) is
    :func:`soft_range` of the output without it; a network output pushed far out (×4) stays inside
    the asymptotes, the unlimited one does not."""
    from conftest import OLD_DNN_MODEL

    from headmotion.systems import load_model

    m = load_model(OLD_DNN_MODEL)
    assert m.range_limit and m.range_.shape == (2, 3)
    y = 4.0 * np.random.default_rng(0).standard_normal((3000, 3)).cumsum(axis=0) / 30.0
    m.set_params(range_limit=False)
    free = m._post(0).push(y, None)
    m.set_params(range_limit=True)
    held = m._post(0).push(y, None)
    np.testing.assert_allclose(held, soft_range(free, m.motion_norm_.mean_, m.range_), atol=1e-12)
    dev = np.abs(held - m.motion_norm_.mean_)
    assert np.all(dev <= m.range_[1] + 1e-12) and np.any(np.abs(free - m.motion_norm_.mean_) > m.range_[1])
