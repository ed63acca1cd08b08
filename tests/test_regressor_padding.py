"""Padding of the regressor's context beyond a sequence's ends (models/nets.py: pad_indices,
PaddedSequences, predict_regressor)."""

import numpy as np
import pytest
import torch

from headmotion.models import nets


def test_pad_indices_edge_and_reflect_match_numpy_pad():
    for n in (1, 2, 3, 7):
        x = np.arange(n)
        for c in (1, 3, 10):
            idx = np.arange(-c, n + c)
            np.testing.assert_array_equal(nets.pad_indices(idx, n, "edge"), np.pad(x, c, mode="edge"))
            want = np.pad(x, c, mode="reflect") if n > 1 else np.zeros(n + 2 * c, int)
            np.testing.assert_array_equal(nets.pad_indices(idx, n, "reflect"), want)


def test_pad_indices_known_values_and_bad_mode():
    np.testing.assert_array_equal(nets.pad_indices([-2, -1, 0, 4, 5, 6], 5, "reflect"), [2, 1, 0, 4, 3, 2])
    with pytest.raises(ValueError, match="padding mode"):
        nets.pad_indices([0], 3, "wrap")


def test_predict_regressor_mirrors_the_context_at_the_ends():
    torch.manual_seed(0)
    net = nets.ContextRegressor(2, context=3, out_dim=3)
    net.eval()
    x = np.random.default_rng(0).standard_normal((9, 2)).astype(np.float32)
    y = nets.predict_regressor(net, x)                     # synthesis pads by mirroring
    y_edge = nets.predict_regressor(net, x, pad="edge")
    mirrored = x[[3, 2, 1, 0, 1, 2, 3]]                     # the window of frame 0, mirrored
    held = x[[0, 0, 0, 0, 1, 2, 3]]                         # ... and with the edge frame held
    with torch.no_grad():
        np.testing.assert_allclose(y[0], net(torch.from_numpy(mirrored.reshape(1, -1)))[0].numpy(), atol=1e-6)
        np.testing.assert_allclose(y_edge[0], net(torch.from_numpy(held.reshape(1, -1)))[0].numpy(), atol=1e-6)
    np.testing.assert_allclose(y[3:6], y_edge[3:6], atol=1e-6)   # frames whose window is inside: alike
    assert not np.allclose(y[-1], y_edge[-1])
