"""The learned classifier of the detectability test (:mod:`.detectability`): a small 1-D
convolutional network on raw 4 s windows of head motion.

Input: each window's rotation minus its own mean (pose-free, degrees at 25 fps) and its velocity,
scaled by the training windows' per-channel SD.  Three convolutions (16, 32, 32 channels, kernel
5, the last two with stride 2), mean- and max-pooling over time, one linear output; about 9,000
weights.  Adam, 40 epochs of mini-batches of 32, class-balanced binary cross-entropy, yaw and roll
mirrored at random (a head turning left is as natural as one turning right; both samples are
augmented alike).  CPU, one thread, seeded: the same seed gives the same probabilities.

Library: torch.
"""

from __future__ import annotations

import numpy as np

EPOCHS = 40
BATCH = 32
LR = 3e-3
WEIGHT_DECAY = 1e-3


def _inputs(W: np.ndarray) -> np.ndarray:
    """(n, T, 3) prepared windows → (n, 6, T) pose-free position and velocity channels."""
    x = W - W.mean(axis=1, keepdims=True)
    v = np.gradient(W, axis=1) * 25.0
    return np.concatenate([x, v], axis=2).transpose(0, 2, 1).astype(np.float32)


def _net():
    import torch.nn as nn

    class Net(nn.Module):
        def __init__(self):
            super().__init__()
            self.body = nn.Sequential(nn.Conv1d(6, 16, 5, padding=2), nn.ReLU(),
                                      nn.Conv1d(16, 32, 5, stride=2, padding=2), nn.ReLU(),
                                      nn.Conv1d(32, 32, 5, stride=2, padding=2), nn.ReLU())
            self.head = nn.Linear(64, 1)

        def forward(self, x):
            import torch

            h = self.body(x)
            return self.head(torch.cat([h.mean(dim=2), h.amax(dim=2)], dim=1))[:, 0]

    return Net()


def fit_predict(W_train: np.ndarray, y_train: np.ndarray, W_test: np.ndarray, *, seed: int = 0) -> np.ndarray:
    """Train on windows ``W_train`` (n, T, 3) with labels ``y_train`` (1 = generated) and return the
    probability that each window of ``W_test`` is generated."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        torch.manual_seed(int(seed) % (2 ** 31))
        rng = np.random.default_rng(seed)
        xtr, xte = _inputs(W_train), _inputs(W_test)
        scale = xtr.transpose(1, 0, 2).reshape(6, -1).std(axis=1) + 1e-6
        xtr, xte = xtr / scale[None, :, None], xte / scale[None, :, None]
        y = np.asarray(y_train, dtype=np.float32)
        pos = max(float(y.sum()), 1.0)
        neg = max(float(len(y) - y.sum()), 1.0)
        net = _net()
        opt = torch.optim.Adam(net.parameters(), lr=LR, weight_decay=WEIGHT_DECAY)
        loss_fn = torch.nn.BCEWithLogitsLoss(pos_weight=torch.tensor(neg / pos))
        X, Y = torch.from_numpy(xtr), torch.from_numpy(y)
        flip = torch.tensor([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])[None, :, None]
        net.train()
        for _ in range(EPOCHS):
            order = rng.permutation(len(X))
            for i in range(0, len(order), BATCH):
                b = torch.from_numpy(order[i:i + BATCH])
                xb = X[b]
                m = torch.from_numpy(rng.random(len(b)) < 0.5)
                xb = torch.where(m[:, None, None], xb * flip, xb)
                opt.zero_grad()
                loss = loss_fn(net(xb), Y[b])
                loss.backward()
                opt.step()
        net.eval()
        with torch.no_grad():
            return torch.sigmoid(net(torch.from_numpy(xte))).numpy().astype(float)
    finally:
        torch.set_num_threads(threads)


__all__ = ["fit_predict"]
