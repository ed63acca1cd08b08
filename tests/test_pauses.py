"""Known-answer tests of settling in pauses."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.motion.pauses import pause_weight, settle_in_pauses
from headmotion.types import Motion

FPS = 100.0


def test_pause_weight_ramps_and_short_gaps():
    m = np.ones(500, bool)
    m[100:300] = False  # 2 s pause
    m[400:420] = False  # 0.2 s gap: not a pause
    w = pause_weight(m, fps=FPS, ramp_s=0.2)
    assert np.all(w[m] == 0) and np.all(w[400:420] == 0)
    assert np.all(w[120:280] == 1.0)
    assert 0 < w[100] < 0.1 and 0 < w[299] < 0.1
    assert np.max(np.abs(np.diff(w))) < 0.1  # smooth


def test_all_speech_is_unchanged():
    x = np.random.default_rng(0).standard_normal((200, 3))
    assert settle_in_pauses(x, np.ones(200, bool), fps=FPS) is x


def test_speed_in_pause_is_idle_times_original_and_rejoins():
    T = 1000
    t = np.arange(T) / FPS
    x = np.stack([np.sin(2 * np.pi * 1.0 * t)] * 3, 1) * 0.05
    m = np.ones(T, bool)
    m[200:500] = False
    y = settle_in_pauses(Motion(x, FPS), m, idle=0.4, ramp_s=0.2, relax_s=1.0).rotvec
    sx = np.abs(np.diff(x[:, 0]))
    sy = np.abs(np.diff(y[:, 0]))
    inner = slice(225, 475)
    assert sy[inner].sum() / sx[inner].sum() == pytest.approx(0.4, rel=1e-6)
    assert np.allclose(y[:200], x[:200])
    assert np.max(np.abs(y[-100:] - x[-100:])) < 0.05 * np.max(np.abs(y[500] - x[500])) + 1e-9  # rejoined
    assert np.max(np.abs(np.diff(y, axis=0))) <= np.max(np.abs(np.diff(x, axis=0))) * 1.2  # no jump


def test_idle_zero_holds_still_and_pull_goes_to_mean():
    T = 600
    x = np.linspace(0, 0.3, T)[:, None] * np.ones(3)
    m = np.ones(T, bool)
    m[100:500] = False
    y = settle_in_pauses(x, m, fps=FPS, idle=0.0, ramp_s=0.0)
    assert np.allclose(y[100:500], y[99])
    mean = np.zeros(3)
    yp = settle_in_pauses(x, m, fps=FPS, idle=0.0, ramp_s=0.0, pull=3.0, mean_pose=mean)
    # 4 s at 3/s: exp(-12) of the distance left
    assert np.all(np.abs(yp[499]) < 1e-4 * np.abs(y[499]) + 1e-9)
    assert np.all(np.abs(yp[300]) < np.abs(yp[150]))


def test_bad_input():
    with pytest.raises(ParameterError):
        settle_in_pauses(np.zeros((10, 3)), np.ones(9, bool), fps=FPS)
    with pytest.raises(ParameterError):
        settle_in_pauses(np.zeros((10, 3)), np.ones(10, bool), fps=FPS, idle=1.5)
    with pytest.raises(ParameterError):
        settle_in_pauses(np.zeros((10, 3)), np.ones(10, bool))


# -- causal mode (streaming systems) ------------------------------------------------
from headmotion.motion.pauses import CausalPauseWeight, PauseSettler  # noqa: E402


def test_causal_weight_known_timing():
    flags = np.ones(400, bool)
    flags[100:250] = False   # 1.5 s of silence
    flags[300:310] = False   # 0.1 s gap between words
    flags[150] = True        # one loud frame inside the pause does not end it
    w = CausalPauseWeight(fps=FPS, delay_s=0.15, full_s=0.5, min_speech_s=0.05, release_s=0.1).push(flags)
    assert np.all(w[:100] == 0) and np.all(w[100:115] == 0)   # nothing until 0.15 s of silence
    assert 0 < w[130] < 1 and np.all(np.diff(w[100:150]) >= 0)
    np.testing.assert_allclose(w[151:250], 1.0, atol=1e-9)   # full idle by 0.5 s, blip ignored
    # speech confirmed after 5 frames, then down to 0 within 0.1 s
    assert w[253] == pytest.approx(1.0) and w[270] == pytest.approx(0.0, abs=1e-9)
    assert np.all(w[300:310] == 0)                            # short gap: no settling


def test_causal_weight_and_settler_chunked_equal_whole():
    rng = np.random.default_rng(3)
    flags = rng.random(1000) < 0.5
    flags[200:500] = False
    x = np.cumsum(rng.standard_normal((1000, 3)), axis=0)
    w_all = CausalPauseWeight(fps=FPS).push(flags)
    y_all = PauseSettler(fps=FPS, idle=0.3).push(x, w_all)
    cw, cs = CausalPauseWeight(fps=FPS), PauseSettler(fps=FPS, idle=0.3)
    parts, i = [], 0
    for n in rng.integers(1, 90, size=200):
        if i >= 1000:
            break
        w = cw.push(flags[i:i + n])
        parts.append(cs.push(x[i:i + n], w))
        i += n
    np.testing.assert_allclose(np.vstack(parts), y_all, rtol=0, atol=1e-12)
    # a causal filter: changing the future does not change the past
    flags2 = flags.copy()
    flags2[700:] = ~flags2[700:]
    y2 = PauseSettler(fps=FPS, idle=0.3).push(x, CausalPauseWeight(fps=FPS).push(flags2))
    np.testing.assert_allclose(y2[:700], y_all[:700], rtol=0, atol=1e-12)


def test_causal_settling_slows_a_pause():
    t = np.arange(600) / FPS
    x = np.stack([np.sin(2 * np.pi * 0.7 * t)] * 3, axis=1)
    mask = np.ones(600, bool)
    mask[200:400] = False
    y = settle_in_pauses(x, mask, fps=FPS, idle=0.25, causal=True)
    sp = lambda z, a, b: np.abs(np.diff(z[a:b], axis=0)).mean()  # noqa: E731
    assert sp(y, 260, 400) == pytest.approx(0.25 * sp(x, 260, 400), rel=1e-9)  # fully settled after 0.5 s
    np.testing.assert_array_equal(y[:200], x[:200])                              # causal: speech before untouched
    assert np.max(np.abs(np.diff(y, axis=0))) <= np.max(np.abs(np.diff(x, axis=0))) * 1.1  # no jump (the offset relaxes at 1/relax_s)


def test_causal_settle_is_causal_and_slows_to_idle():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.standard_normal((600, 3)), axis=0)
    m = np.ones(600, bool)
    m[100:400] = False
    y = settle_in_pauses(x, m, fps=FPS, idle=0.25, causal=True, mean_pose=np.zeros(3))
    np.testing.assert_allclose(y[:100], x[:100])  # speech: untouched
    sp = lambda z, a, b: np.abs(np.diff(z[a:b], axis=0)).sum()  # noqa: E731
    assert sp(y, 180, 400) == pytest.approx(0.25 * sp(x, 180, 400), rel=1e-9)
    x2 = x.copy()
    x2[300:] += 5.0
    y2 = settle_in_pauses(x2, m, fps=FPS, idle=0.25, causal=True, mean_pose=np.zeros(3))
    np.testing.assert_array_equal(y2[:300], y[:300])
