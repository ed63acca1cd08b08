"""motion/iir.py: scipy.signal's lfilter and butter, bit for bit, without importing scipy.signal."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.motion import iir

signal = pytest.importorskip("scipy.signal")


@pytest.mark.parametrize("order, cutoff, fs", [(2, 0.5, 100.0), (2, 1.5, 100.0), (2, 4.0, 100.0), (1, 3.0, 25.0),
                                               (3, 2.0, 50.0)])
def test_butter_lowpass_equals_scipy(order, cutoff, fs):
    b, a = iir.butter_lowpass(order, cutoff, fs)
    sb, sa = signal.butter(order, cutoff, fs=fs)
    np.testing.assert_array_equal(b, sb)
    np.testing.assert_array_equal(a, sa)


@pytest.mark.parametrize("ba", [([1.0], [1.0, -0.97]), "butter", ([0.2, 0.3, 0.1, 0.05], [2.0, -0.5, 0.1, 0.02])])
def test_lfilter_equals_scipy_bit_for_bit_and_chunks_equal_one_call(ba):
    b, a = signal.butter(2, 1.5, fs=100.0) if ba == "butter" else ba
    rng = np.random.default_rng(0)
    x = rng.standard_normal((700, 3))
    n = max(len(a), len(b)) - 1
    zi = rng.standard_normal((n, 3))
    np.testing.assert_array_equal(iir.lfilter(b, a, x), signal.lfilter(b, a, x, axis=0))
    y, zf = iir.lfilter(b, a, x, zi=zi)
    sy, szf = signal.lfilter(b, a, x, axis=0, zi=zi)
    np.testing.assert_array_equal(y, sy)
    np.testing.assert_array_equal(zf, szf)
    z, parts = zi, []
    for lo, hi in ((0, 1), (1, 250), (250, 700)):
        p, z = iir.lfilter(b, a, x[lo:hi], zi=z)
        parts.append(p)
    np.testing.assert_array_equal(np.concatenate(parts), y)
    np.testing.assert_array_equal(iir.lfilter(b, a, x[:, 0]), signal.lfilter(b, a, x[:, 0]))


def test_known_answers():
    # an impulse through y_t = x_t + 0.5 y_{t-1}: 1, 0.5, 0.25, ...
    np.testing.assert_array_equal(iir.lfilter([1.0], [1.0, -0.5], np.eye(1, 5)[0]), [1, 0.5, 0.25, 0.125, 0.0625])
    # a low-pass passes a constant with unit gain
    b, a = iir.butter_lowpass(2, 2.0, 100.0)
    assert iir.lfilter(b, a, np.ones(2000))[-1] == pytest.approx(1.0, abs=1e-9)
    with pytest.raises(ValueError, match="cutoff"):
        iir.butter_lowpass(2, 60.0, 100.0)
