"""Per-dimension mean/variance normalisation fitted on training data (paper §4.1: "All the features
were normalised in terms of variance for each dimension").

:class:`Normalizer` follows scikit-learn's estimator style (parameters in ``__init__``, work in
``fit``, fitted attributes end in ``_``) and stores itself as plain arrays (:meth:`to_arrays` /
:meth:`from_arrays`) for model files — never pickle.  ``sklearn.preprocessing.StandardScaler`` was
considered; it is not used because it cannot take a list of sequences or a FeatureTrack and its
state is not a plain-array dict.
"""

from __future__ import annotations

import numpy as np

from ..errors import NotFittedError, ParameterError
from ..types import FeatureTrack


def _as_array(x) -> np.ndarray:
    if isinstance(x, FeatureTrack):
        return np.asarray(x.values, dtype=np.float64)
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ParameterError(f"Normalizer expects (T, D) arrays or FeatureTracks; got shape {a.shape}")
    return a


class Normalizer:
    """Per-dimension standardisation ``(x − mean_) / std_``.

    Parameters
    ----------
    with_mean : bool
        Subtract the mean (default).  ``False`` divides by the standard deviation only.
    min_std : float
        Standard deviations below this (constant dimensions) are replaced by 1.

    Attributes
    ----------
    mean_ : np.ndarray [shape=(D,)]
    std_ : np.ndarray [shape=(D,)]
    n_frames_ : int, frames seen in ``fit``
    """

    def __init__(self, *, with_mean: bool = True, min_std: float = 1e-8):
        self.with_mean = with_mean
        self.min_std = min_std

    def fit(self, data) -> "Normalizer":
        """Fit on one ``(T, D)`` array/track or a list of them (concatenated along time)."""
        if isinstance(data, (FeatureTrack, np.ndarray)):
            data = [data]
        arrays = [_as_array(x) for x in data]
        if not arrays:
            raise ParameterError("Normalizer.fit needs at least one array; got an empty list")
        dims = {a.shape[1] for a in arrays}
        if len(dims) != 1:
            raise ParameterError(f"Normalizer.fit: arrays have different dimensions {sorted(dims)}")
        X = np.concatenate(arrays, axis=0)
        if len(X) == 0:
            raise ParameterError("Normalizer.fit: the arrays hold no frames")
        if not np.all(np.isfinite(X)):
            raise ParameterError("Normalizer.fit: input contains NaN or inf")
        self.mean_ = X.mean(axis=0) if self.with_mean else np.zeros(X.shape[1])
        std = X.std(axis=0)
        self.std_ = np.where(std < self.min_std, 1.0, std)
        self.n_frames_ = int(len(X))
        return self

    def _check(self, d: int) -> None:
        if not hasattr(self, "mean_"):
            raise NotFittedError("Normalizer is not fitted; call fit() or from_arrays() first")
        if d != len(self.mean_):
            raise ParameterError(f"Normalizer was fitted on {len(self.mean_)} dims; given {d}")

    def transform(self, x):
        """``(x − mean_) / std_``; returns the same type (array or FeatureTrack)."""
        a = _as_array(x)
        self._check(a.shape[1])
        out = (a - self.mean_) / self.std_
        if isinstance(x, FeatureTrack):
            return FeatureTrack(out, x.fps, x.names)
        return out

    def inverse_transform(self, x):
        """``x · std_ + mean_``; returns the same type."""
        a = _as_array(x)
        self._check(a.shape[1])
        out = a * self.std_ + self.mean_
        if isinstance(x, FeatureTrack):
            return FeatureTrack(out, x.fps, x.names)
        return out

    def fit_transform(self, data):
        """Fit, then transform ``data`` (a list gives a list)."""
        self.fit(data)
        if isinstance(data, (list, tuple)):
            return [self.transform(x) for x in data]
        return self.transform(data)

    @staticmethod
    def _key(prefix: str, name: str) -> str:
        """``"norm" -> "norm_mean"``; a prefix ending in ``_``, ``.`` or ``/`` is used as is."""
        if not prefix or prefix.endswith(("_", ".", "/")):
            return f"{prefix}{name}"
        return f"{prefix}_{name}"

    def to_arrays(self, prefix: str = "norm") -> dict[str, np.ndarray]:
        """``{<prefix>_mean, <prefix>_std}`` float64 ``(D,)`` arrays (for an npz / model file);
        ``to_arrays("norm_")`` gives ``norm_mean`` / ``norm_std``."""
        self._check(len(getattr(self, "mean_", [])))
        return {self._key(prefix, "mean"): np.asarray(self.mean_, np.float64),
                self._key(prefix, "std"): np.asarray(self.std_, np.float64)}

    @classmethod
    def from_arrays(cls, arrays, prefix: str = "norm") -> "Normalizer":
        """Rebuild from :meth:`to_arrays` output (any mapping, e.g. an ``np.load`` npz)."""
        try:
            mean = np.asarray(arrays[cls._key(prefix, "mean")], dtype=np.float64)
            std = np.asarray(arrays[cls._key(prefix, "std")], dtype=np.float64)
        except KeyError as exc:
            raise ParameterError(f"normaliser arrays lack {exc.args[0]!r}") from None
        if mean.shape != std.shape or mean.ndim != 1 or np.any(std <= 0):
            raise ParameterError(f"normaliser arrays are inconsistent: mean {mean.shape}, std {std.shape}")
        obj = cls()
        obj.mean_, obj.std_, obj.n_frames_ = mean, std, 0
        return obj


__all__ = ["Normalizer"]
