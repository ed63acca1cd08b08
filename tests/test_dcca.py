"""The differentiable CCA of the CCCAE objective (paper §3.1 eq 1; headmotion.models.dcca)."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from headmotion.models.dcca import canonical_correlations, cca_objective  # noqa: E402


pytestmark = pytest.mark.usefixtures("torch_one_thread")


def svd_cca(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Closed-form reference: singular values of Qxᵀ Qy for orthonormal bases of the centred data."""
    qx, _ = np.linalg.qr(x - x.mean(0))
    qy, _ = np.linalg.qr(y - y.mean(0))
    return np.linalg.svd(qx.T @ qy, compute_uv=False)


@pytest.fixture
def views(rng):
    x = rng.normal(size=(400, 8))
    y = x[:, :3] @ rng.normal(size=(3, 3)) + 1.5 * rng.normal(size=(400, 3))
    return x, y


def test_matches_closed_form_svd(views):
    x, y = views
    ref = svd_cca(x, y)
    assert ref[0] > 0.5 and ref[-1] < ref[0]  # a non-trivial case
    got = float(cca_objective(torch.tensor(x), torch.tensor(y), reg=0.0))
    assert got == pytest.approx(ref.sum(), abs=1e-3)
    for k in (1, 2, 3):
        assert float(cca_objective(torch.tensor(x), torch.tensor(y), k=k, reg=0.0)) == pytest.approx(ref[:k].sum(), abs=1e-3)
    np.testing.assert_allclose(canonical_correlations(x, y), ref, atol=1e-3)


def test_matches_sklearn_first_component(views):
    from sklearn.cross_decomposition import CCA

    x, y = views
    u, v = CCA(n_components=1, max_iter=5000, tol=1e-10).fit(x, y).transform(x, y)
    rho = abs(np.corrcoef(u[:, 0], v[:, 0])[0, 1])
    assert float(cca_objective(torch.tensor(x), torch.tensor(y), k=1, reg=0.0)) == pytest.approx(rho, abs=1e-3)


def test_float32_and_default_regulariser_close(views):
    x, y = views
    ref = svd_cca(x, y).sum()
    got = float(cca_objective(torch.tensor(x, dtype=torch.float32), torch.tensor(y, dtype=torch.float32)))
    assert got == pytest.approx(ref, abs=1e-2)  # the 1e-3 relative ridge lowers it slightly
    assert got <= ref + 1e-4


def test_known_answers(rng):
    y = rng.normal(size=(200, 3))
    # an invertible linear map of y is perfectly correlated with y: every correlation is 1
    x = y @ rng.normal(size=(3, 3)) + 5.0
    assert float(cca_objective(torch.tensor(x), torch.tensor(y), reg=0.0)) == pytest.approx(3.0, abs=1e-6)
    # scale invariance (the ridge is relative)
    a = float(cca_objective(torch.tensor(x), torch.tensor(y)))
    b = float(cca_objective(torch.tensor(1e3 * x), torch.tensor(1e-2 * y)))
    assert a == pytest.approx(b, rel=1e-9)
    # a constant view does not crash and has (near) zero correlation
    c = float(cca_objective(torch.zeros(200, 4, dtype=torch.float64), torch.tensor(y)))
    assert c < 1e-3


def test_gradcheck_float64(rng):
    x = torch.tensor(rng.normal(size=(40, 5)), requires_grad=True)
    y = torch.tensor(rng.normal(size=(40, 3)) + 0.5 * x.detach().numpy()[:, :3], requires_grad=True)
    assert torch.autograd.gradcheck(lambda a, b: cca_objective(a, b, reg=1e-3), (x, y), eps=1e-6, atol=1e-5)
    assert torch.autograd.gradcheck(lambda a, b: cca_objective(a, b, k=1, reg=0.0), (x, y), eps=1e-6, atol=1e-5)


def test_gradient_ascent_increases_correlation(rng):
    """Following the gradient makes a linear projection of x more correlated with y."""
    x = torch.tensor(rng.normal(size=(500, 10)))
    y = torch.tensor(x.numpy()[:, :3] ** 2 + 0.1 * rng.normal(size=(500, 3)))
    w = torch.tensor(rng.normal(size=(10, 4)), requires_grad=True)
    feats = lambda: torch.cat([x @ w, (x @ w) ** 2], 1)  # noqa: E731
    with torch.no_grad():
        before = float(cca_objective(feats(), y))
    opt = torch.optim.Adam([w], lr=0.05)
    for _ in range(100):
        loss = -cca_objective(feats(), y)
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        assert float(cca_objective(feats(), y)) > before + 0.5


def test_bad_shapes():
    with pytest.raises(ValueError, match="m, p"):
        cca_objective(torch.zeros(10, 3), torch.zeros(9, 3))
    with pytest.raises(ValueError, match="k must be"):
        cca_objective(torch.randn(10, 3), torch.randn(10, 2), k=3)
