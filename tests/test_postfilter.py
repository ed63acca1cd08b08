"""The post-filter (paper §3.3, §4.2): a denoising autoencoder on 50-frame motion segments,
applied with overlap-add (headmotion.models.nets)."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from headmotion.models import nets  # noqa: E402


pytestmark = pytest.mark.usefixtures("torch_one_thread")


def clean_motion(T: int, seed: int) -> np.ndarray:
    """Smooth head-motion-like trajectories (the planted template-warping process), z-scored."""
    from scipy.ndimage import gaussian_filter1d

    from headmotion.synthetic import planted_rotvec

    rng = np.random.default_rng(seed)
    e = np.clip(gaussian_filter1d(rng.uniform(0, 1, T), 20) * 3 - 1, 0, 1)
    rv = planted_rotvec(e, fps=100.0, rng=rng)
    return ((rv - rv.mean(0)) / rv.std(0)).astype(np.float32)


@pytest.fixture(scope="module")
def dae():
    torch.set_num_threads(1)
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(0)
        net = nets.make_postfilter(segment=50, hidden=(128,), code_dim=32)
        train = nets.motion_segments([clean_motion(20000, 1)], segment=50, hop=5)
        valid = nets.motion_segments([clean_motion(3000, 2)], segment=50, hop=10)
        hist = nets.train_postfilter(net, train, valid, noise=0.3, max_epochs=6, patience=6, pretrain_epochs=1)
    assert hist["valid"][hist["best_epoch"]] < hist["valid"][0]
    return net


def jitter(y: np.ndarray) -> float:
    return float(np.mean(np.diff(y, axis=0) ** 2))


def xcorr_peak_lag(a: np.ndarray, b: np.ndarray, max_lag: int = 20) -> int:
    a = (a - a.mean()) / a.std()
    b = (b - b.mean()) / b.std()
    lags = range(-max_lag, max_lag + 1)
    vals = [np.mean(a[max(0, k):len(a) + min(0, k)] * b[max(0, -k):len(b) + min(0, -k)]) for k in lags]
    return list(lags)[int(np.argmax(vals))]


def test_postfilter_smooths_without_shifting(dae):
    rng = np.random.default_rng(7)
    clean = clean_motion(3000, 3)
    noisy = clean + 0.3 * rng.standard_normal(clean.shape).astype(np.float32)
    out = nets.apply_postfilter(dae, noisy, segment=50)
    assert out.shape == noisy.shape and out.dtype == np.float32
    assert jitter(out) < 0.25 * jitter(noisy), (jitter(out), jitter(noisy))
    assert np.mean((out - clean) ** 2) < 0.9 * np.mean((noisy - clean) ** 2)
    for k in range(3):
        assert xcorr_peak_lag(out[:, k], noisy[:, k]) == 0
        assert xcorr_peak_lag(out[:, k], clean[:, k]) == 0
    # the level of the trajectory is kept (segment means pass through)
    np.testing.assert_allclose(out.mean(0), noisy.mean(0), atol=0.05)


def test_overlap_add_lengths_and_levels(dae):
    for T in (1, 7, 49, 50, 51, 75, 123):
        y = clean_motion(max(T, 60), T)[:T] + 5.0
        out = nets.apply_postfilter(dae, y, segment=50)
        assert out.shape == (T, 3)
        assert np.all(np.isfinite(out))
        assert abs(float(out.mean()) - float(y.mean())) < 0.5
    assert nets.apply_postfilter(dae, np.zeros((0, 3)), segment=50).shape == (0, 3)


def test_overlap_add_of_identity_is_exact():
    """With a network that returns its input, overlap-add reconstructs the input exactly."""

    class Identity(torch.nn.Module):
        def forward(self, x):
            return x

    y = np.random.default_rng(0).standard_normal((333, 3)).astype(np.float32)
    for hop in (25, 10, 50):
        np.testing.assert_allclose(nets.apply_postfilter(Identity(), y, segment=50, hop=hop), y, atol=1e-5)


def test_segments_are_mean_removed():
    y = clean_motion(500, 4) + 3.0
    seg = nets.motion_segments([y, y[:30]], segment=50, hop=25)
    assert seg.shape == (19, 50, 3)  # the 30-frame sequence is too short for a segment
    np.testing.assert_allclose(seg.mean(axis=1), 0.0, atol=1e-5)
