"""Differentiable canonical correlation, the CCA term of the CCCAE objective (paper §3.1, eq 1).

Function ``cca_objective: (H1 (m, p), H2 (m, q)) -> scalar`` — the sum of the ``k`` largest
canonical correlations between two views of the same ``m`` samples, written in torch so that its
gradient flows into the network that produced ``H1`` (deep CCA, Andrew et al. 2013; the DCCAE of
Wang et al. 2015, the paper's reference [13]).

Computation
-----------
Both views are centred within the mini-batch; the covariances are

    Σ11 = H1ᵀH1 / (m - 1) + r·tr(Σ11)/p · I,   Σ22 likewise,   Σ12 = H1ᵀH2 / (m - 1)

and the canonical correlations are the singular values of ``T = Σ11^-½ Σ12 Σ22^-½``.  Deep CCA
forms ``Σ^-½`` by an eigendecomposition; we whiten with Cholesky factors instead
(``T' = L1⁻¹ Σ12 L2⁻ᵀ`` with ``Σ = L Lᵀ``), which has exactly the same singular values
(``L⁻¹ = Q Σ^-½`` for an orthogonal ``Q``) but whose gradient stays finite when eigenvalues of
``Σ11`` repeat — the eigenvector derivative of ``eigh`` divides by eigenvalue gaps.  The singular
values are the square roots of the eigenvalues of the small ``q × q`` matrix ``T'ᵀT'`` (``q = 3``
for head rotation), clamped at ``eps`` before the square root.

Regulariser and batch size (our choices; the paper states neither)
-------------------------------------------------------------------
* ``reg = 1e-3`` **relative** to the mean variance of each view (ridge ``r·tr(Σ)/p``): this keeps
  the Cholesky factorisation defined when a hidden unit is dead or two units are collinear, and,
  being relative, leaves the objective invariant to the scale of the embedding (the absolute
  ``r₁ = r₂ = 1e-4`` of deep CCA depends on the activations' scale).  It lowers a perfect
  correlation of 1 by about ``1e-3``.
* mini-batches of **1000 frames** (10 s of speech at 100 frames/s) for the CCCAE (see
  :mod:`headmotion.models.nets`): the batch estimate of canonical correlation is biased upwards by
  roughly ``sqrt(p / m)`` (≈ 0.17 for a 30-dim embedding), so the batch must be large compared with
  the embedding dimension (Wang et al. found mini-batches of a few hundred to a few thousand
  samples enough for deep CCA with SGD), while still giving several updates per epoch on a few
  minutes of speech.

Library considered: scikit-learn's ``CCA`` (NIPALS, numpy, not differentiable) — used only as the
closed-form reference in the tests; the evaluation metrics (local/global CCA) live in
:mod:`headmotion.evaluation.measures.metrics`, not here.
"""

from __future__ import annotations

DEFAULT_REG = 1e-3
DEFAULT_CCA_BATCH = 1000


def cca_objective(h1, h2, *, k: int | None = None, reg: float = DEFAULT_REG, eps: float = 1e-9):
    """Sum of the ``k`` largest canonical correlations between ``h1`` and ``h2`` (differentiable).

    Parameters
    ----------
    h1 : torch.Tensor [shape=(m, p)]
    h2 : torch.Tensor [shape=(m, q)]
    k : int or None
        Number of correlations summed; ``None`` means all ``min(p, q)``.
    reg : float
        Ridge added to each covariance, relative to its mean variance (``reg * tr(Σ) / dim``).
    eps : float
        Floor of the squared correlations before the square root (keeps the gradient finite).

    Returns
    -------
    torch.Tensor, scalar, in ``[0, k]``.
    """
    import torch

    if h1.ndim != 2 or h2.ndim != 2 or h1.shape[0] != h2.shape[0]:
        raise ValueError(f"cca_objective needs (m, p) and (m, q) tensors; got {tuple(h1.shape)} and {tuple(h2.shape)}")
    m, p = h1.shape
    q = h2.shape[1]
    if m < 2:
        raise ValueError(f"cca_objective needs at least 2 samples; got {m}")
    kk = min(p, q) if k is None else int(k)
    if not 1 <= kk <= min(p, q):
        raise ValueError(f"k must be in [1, {min(p, q)}]; got {k}")
    h1 = h1 - h1.mean(dim=0, keepdim=True)
    h2 = h2 - h2.mean(dim=0, keepdim=True)
    s11 = h1.T @ h1 / (m - 1)
    s22 = h2.T @ h2 / (m - 1)
    s12 = h1.T @ h2 / (m - 1)
    eye1 = torch.eye(p, dtype=h1.dtype, device=h1.device)
    eye2 = torch.eye(q, dtype=h2.dtype, device=h2.device)
    # relative ridge, plus a tiny absolute floor so an all-constant view still factorises
    tiny = torch.finfo(h1.dtype).eps
    s11 = s11 + (reg * torch.diagonal(s11).mean() + tiny) * eye1
    s22 = s22 + (reg * torch.diagonal(s22).mean() + tiny) * eye2
    l1 = torch.linalg.cholesky(s11)
    l2 = torch.linalg.cholesky(s22)
    # T' = L1^-1 S12 L2^-T
    a = torch.linalg.solve_triangular(l1, s12, upper=False)            # L1^-1 S12        (p, q)
    t = torch.linalg.solve_triangular(l2, a.T, upper=False).T          # (L2^-1 (L1^-1 S12)^T)^T
    if q <= p:
        g = t.T @ t                                                    # (q, q)
    else:
        g = t @ t.T                                                    # (p, p)
    ev = torch.linalg.eigvalsh(g)                                      # ascending
    ev = torch.clamp(ev, min=eps)
    return torch.sqrt(ev[-kk:]).sum()


def canonical_correlations(h1, h2, *, reg: float = 0.0):
    """All canonical correlations (descending) of two numpy arrays, by the same whitening — a
    convenience for diagnostics; returns ``np.ndarray [shape=(min(p, q),)]``."""
    import numpy as np
    import torch

    a = torch.as_tensor(np.asarray(h1, dtype=np.float64))
    b = torch.as_tensor(np.asarray(h2, dtype=np.float64))
    out = []
    n = min(a.shape[1], b.shape[1])
    total_prev = 0.0
    with torch.no_grad():
        for kk in range(1, n + 1):
            total = float(cca_objective(a, b, k=kk, reg=reg))
            out.append(total - total_prev)
            total_prev = total
    return np.asarray(out)


__all__ = ["cca_objective", "canonical_correlations", "DEFAULT_REG", "DEFAULT_CCA_BATCH"]
