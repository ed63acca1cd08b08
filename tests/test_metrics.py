"""Known-answer tests of headmotion.evaluation.measures.metrics (thesis §4.3, Table 3.4; paper §4.3)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import LengthMismatchError, ParameterError
from headmotion.evaluation.measures import metrics as M
from headmotion.types import FeatureTrack, Motion


def test_nmse_known_answers(rng):
    y = rng.normal(size=(500, 3)) * [0.1, 0.2, 0.05]
    r = M.nmse(y, y)
    assert r.mean == 0.0 and np.all(r.per_axis == 0)
    r = M.nmse(y, np.broadcast_to(y.mean(0), y.shape))
    np.testing.assert_allclose(r.per_axis, 1.0, rtol=1e-12)
    assert r.mean == pytest.approx(1.0)
    # scaled error: pred = y + e with var(e) = var(y)/4 per axis
    e = rng.normal(size=y.shape)
    e = (e - e.mean(0)) / e.std(0) * y.std(0) / 2
    assert M.nmse(y, y + e).mean == pytest.approx(0.25, rel=0.05)


def test_nmse_accepts_motion_and_constant_axis():
    rv = np.zeros((100, 3))
    rv[:, 0] = np.sin(np.arange(100) / 5)
    m = Motion(rv, 100.0)
    r = M.nmse(m, np.zeros((100, 3)))
    assert np.isnan(r.per_axis[1]) and np.isnan(r.per_axis[2])
    assert r.mean == pytest.approx(r.per_axis[0])


def test_cca_linear_map_is_one(rng):
    y = rng.normal(size=(800, 3))
    A = rng.normal(size=(3, 3))
    assert M.cca(y, y @ A + 2.5) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(M.global_cca(y, y @ A - 1, all_components=True), 1.0, atol=1e-5)
    # different widths: 3-d motion vs 6-d features containing a linear image of it
    f = np.hstack([y @ A, rng.normal(size=(800, 3))])
    s = M.cca(y, f, all_components=True)
    assert s.shape == (3,)
    np.testing.assert_allclose(s, 1.0, atol=1e-5)


def test_cca_sorted_and_known_single_correlation(rng):
    n = 20000
    z = rng.normal(size=n)
    x = np.column_stack([z + rng.normal(size=n), rng.normal(size=n)])
    y = np.column_stack([rng.normal(size=n), z + rng.normal(size=n)])
    s = M.cca(x, y, all_components=True)
    assert s[0] >= s[1]
    assert s[0] == pytest.approx(0.5, abs=0.02)  # cor(z+e1, z+e2) = 1/2
    assert s[1] < 0.03


def test_cca_independent_noise_small_sample_bias():
    # for one column each, E[r^2] = 1/(T-1) exactly under independence
    rng = np.random.default_rng(7)
    T = 40
    r2 = [M.cca(rng.normal(size=T), rng.normal(size=T)) ** 2 for _ in range(2000)]
    assert np.mean(r2) == pytest.approx(1 / (T - 1), rel=0.12)
    # 3 x 3 dims: the first canonical correlation of noise shrinks like 1/sqrt(T)
    small = np.mean([M.cca(rng.normal(size=(300, 3)), rng.normal(size=(300, 3))) for _ in range(50)])
    large = np.mean([M.cca(rng.normal(size=(30000, 3)), rng.normal(size=(30000, 3))) for _ in range(10)])
    assert 0.08 < small < 0.25
    assert large < 0.03
    assert small / large == pytest.approx(10, rel=0.35)


def test_cca_constant_stream_is_zero(rng):
    f = rng.normal(size=(300, 4))
    assert M.cca(np.zeros((300, 3)), f) == 0.0
    assert M.cca(np.full((300, 3), 0.3), f) == 0.0
    # one constant column does not create spurious correlation
    x = np.column_stack([rng.normal(size=300), np.full(300, 7.0), rng.normal(size=300)])
    y = x[:, [0]] * 2 + 1
    assert M.cca(x, y) == pytest.approx(1.0, abs=1e-6)


def test_fcca_of_original_equals_cca(rng):
    T = 2000
    f = rng.normal(size=(T, 6))
    X = f[:, :3] @ rng.normal(size=(3, 3)) + rng.normal(size=(T, 3)) * 2
    assert M.fcca(X, f, X) == pytest.approx(M.cca(X, f), abs=1e-8)
    # a desynchronised copy scores near 0, a still head exactly 0, a scaled copy the same as X
    assert M.fcca(X, f, np.roll(X, 500, axis=0)) < 0.1
    assert M.fcca(X, f, np.zeros_like(X)) == 0.0
    assert M.fcca(X, f, 0.1 * X + 3) == pytest.approx(M.cca(X, f), abs=1e-8)
    # windowed FCCA of the original = local CCA
    assert M.fcca(X, f, X, window=250) == pytest.approx(M.local_cca(X, f, window=250), abs=1e-8)


def test_fcca_accepts_types(rng):
    T = 500
    f = FeatureTrack(rng.normal(size=(T, 6)).astype(np.float32), 100.0, tuple("abcdef"))
    m = Motion(rng.normal(size=(T, 3)) * 0.05, 100.0)
    assert M.fcca(m, f, m) == pytest.approx(M.cca(m, f), abs=1e-6)


def test_local_cca_windows_and_seconds(rng):
    x = rng.normal(size=(1000, 3))
    y = rng.normal(size=(1000, 3))
    per = M.local_cca(x, y, window=300, return_windows=True)
    assert per.shape == (3,)  # tail of 100 frames dropped
    assert per[1] == pytest.approx(M.cca(x[300:600], y[300:600]))
    mx = Motion(x, 100.0)
    assert M.local_cca(mx, y, window_s=3.0) == pytest.approx(M.local_cca(x, y, window=300))
    assert M.local_cca(x, y, window_s=2.0, fps=50) == pytest.approx(M.local_cca(x, y, window=100))
    assert M.local_cca(x, y, window=100, hop=50, return_windows=True).shape == (19,)
    # shorter than a window: the whole sequence
    assert M.local_cca(x[:200], y[:200]) == pytest.approx(M.cca(x[:200], y[:200]))
    with pytest.raises(ParameterError, match="fps"):
        M.local_cca(x, y, window_s=3.0)


def test_local_cca_approaches_global_as_window_grows():
    # thesis Fig 4.8: short windows find spurious correlation; it shrinks towards the global value
    rng = np.random.default_rng(3)
    T = 12000
    z = rng.normal(size=T)
    x = np.column_stack([z + 2 * rng.normal(size=T), rng.normal(size=T), rng.normal(size=T)])
    y = np.column_stack([z + 2 * rng.normal(size=T), rng.normal(size=(T, 5))])
    g = M.cca(x, y)
    gaps = [M.local_cca(x, y, window=w) - g for w in (200, 500, 1000, 3000, 6000, 12000)]
    assert gaps[0] > 0.05
    assert all(a >= b - 0.01 for a, b in zip(gaps, gaps[1:]))
    assert gaps[-1] == pytest.approx(0.0, abs=1e-12)


def test_length_mismatch(rng):
    x = rng.normal(size=(100, 3))
    assert M.cca(x, np.vstack([x, x[:1]])) == pytest.approx(1.0, abs=1e-6)  # one frame trimmed
    with pytest.raises(LengthMismatchError, match="100 frames"):
        M.cca(x, rng.normal(size=(120, 3)))
    with pytest.raises(ParameterError, match="NaN"):
        M.cca(np.full((10, 2), np.nan), x[:10])


def test_sd_and_jerk_known_answers():
    fps = 100.0
    t = np.arange(2000) / fps
    f = 1.5
    amp = 0.1
    rv = np.column_stack([amp * np.sin(2 * np.pi * f * t), np.zeros_like(t), np.zeros_like(t)])
    s = M.sd_stats(Motion(rv, fps))
    assert s.sd[0] == pytest.approx(amp / np.sqrt(2), rel=1e-3)
    w = 2 * np.pi * f
    assert s.sd_velocity[0] == pytest.approx(amp * w / np.sqrt(2), rel=1e-2)
    assert s.sd[1] == 0 and s.sd_velocity[1] == 0
    jerk, acc = M.jerk_accel(rv, fps=fps)
    # mean |sin| = 2/pi
    assert acc == pytest.approx(amp * w ** 2 * 2 / np.pi, rel=1e-2)
    assert jerk == pytest.approx(amp * w ** 3 * 2 / np.pi, rel=1e-2)
    # frame-rate aware: the same motion sampled at 50 fps gives the same physical values
    rv50 = rv[::2]
    jerk50, acc50 = M.jerk_accel(Motion(rv50, 50.0))
    assert acc50 == pytest.approx(acc, rel=0.02)
    with pytest.raises(ParameterError, match="frame rate"):
        M.jerk_accel(rv)


def test_distribution_stats_normal_vs_heavy_tails():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(20000, 3)) * 0.05
    d = M.distribution_stats(x)
    assert list(d) == ["rx", "ry", "rz", "Δrx", "Δry", "Δrz", "ΔΔrx", "ΔΔry", "ΔΔrz"]
    assert abs(d["rx"]["skew"]) < 0.05
    assert d["rx"]["kurtosis"] == pytest.approx(3.0, abs=0.15)
    assert d["rx"]["ks"] < 0.02
    assert d["rx"]["ks_std_normal"] > 0.4  # tiny data vs N(0, 1), like the thesis' table
    lap = rng.laplace(size=(20000, 3))
    assert M.distribution_stats(lap)["rx"]["kurtosis"] == pytest.approx(6.0, rel=0.15)
    assert M.distribution_stats(lap)["rx"]["ks"] > 0.03
