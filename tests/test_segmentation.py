"""Segmentation at extrema (thesis §5.2)."""

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.motion.segmentation import find_extrema, min_segment_frames, segment, segment_axis, smooth


def test_boundaries_at_extrema_of_a_sinusoid():
    fps = 100.0
    t = np.arange(400) / fps
    x = np.sin(2 * np.pi * 1.0 * t)  # extrema at 0.25, 0.75, 1.25, ... s
    b = segment_axis(x, fps=fps)
    assert b[0] == 0 and b[-1] == 399
    np.testing.assert_allclose(b[1:-1], [25, 75, 125, 175, 225, 275, 325, 375], atol=1)


def test_minimum_segment_length_and_alternation():
    rng = np.random.default_rng(0)
    fps = 100.0
    x = np.cumsum(rng.normal(size=3000)) * 0.01 + 0.02 * rng.normal(size=3000)
    seg = segment(x, fps=fps)
    d = seg.durations
    assert d.min() >= min_segment_frames(fps) or len(d) == 1
    # interior segments alternate in direction
    s = np.sign(seg.amplitudes[1:-1])
    assert np.all(s[1:] * s[:-1] < 0)


def test_min_segment_scales_with_fps():
    assert min_segment_frames(100) == 6
    assert min_segment_frames(200) == 12
    assert min_segment_frames(25) == 2


def test_fast_wiggles_are_merged():
    fps = 100.0
    t = np.arange(600) / fps
    x = np.sin(2 * np.pi * 0.5 * t) + 0.001 * np.sin(2 * np.pi * 20 * t)  # 20 Hz ripple
    b = segment_axis(x, fps=fps)
    assert len(b) - 1 <= 7  # 0.5 Hz over 6 s: ~6 half cycles, the ripple adds none


def test_short_and_flat_inputs():
    assert list(segment_axis(np.zeros(1), fps=100)) == [0]
    assert list(segment_axis(np.zeros(50), fps=100)) == [0, 49]
    assert len(find_extrema(np.array([1.0, 2.0]))) == 0
    with pytest.raises(ParameterError, match="1-D"):
        segment_axis(np.zeros((10, 2)), fps=100)


def test_smoothing_is_5_frames_wide_at_100hz():
    x = np.zeros(21)
    x[10] = 1.0
    y = smooth(x, fps=100)
    assert np.count_nonzero(y > 1e-12) == 5


def test_min_swing_ignores_jitter_but_keeps_real_turns():
    from headmotion.motion.segmentation import noise_sd, segment_axis, zigzag_extrema

    fps = 100.0
    t = np.arange(600) / fps
    slow = 0.1 * np.sin(2 * np.pi * 0.5 * t)  # extrema at 0.5, 1.5, 2.5, ... s
    jitter = 0.004 * np.sin(2 * np.pi * 7.0 * t + 0.3)  # small fast wiggles
    x = slow + jitter
    b_lit = segment_axis(x, fps=fps)
    b = segment_axis(x, fps=fps, min_swing=0.05)
    assert len(b_lit) > len(b)
    inner = b[1:-1] / fps
    assert len(inner) == 6 and np.allclose(inner, [0.5, 1.5, 2.5, 3.5, 4.5, 5.5], atol=0.06)
    # alternation max/min and every swing at least min_swing
    sw = np.abs(np.diff(x[zigzag_extrema(x, 0.05)]))
    assert np.all(sw >= 0.05)
    assert segment_axis(x, fps=fps, min_swing=0.0).tolist() == b_lit.tolist()
    rng = np.random.default_rng(0)
    assert noise_sd(slow + 0.01 * rng.standard_normal(len(t)), fps=fps) == pytest.approx(0.01, rel=0.3)
