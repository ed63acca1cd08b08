"""The registered DNN systems: one class per input (paper §3–4, Table 1)."""

from __future__ import annotations

from ..base import EMBEDDING, STREAMING
from .system import DnnSystem


class CccaeSystem(DnnSystem):
    """M_CCCAE (paper §3): waveform → CCCAE embedding (α = 1 by default) → regressor → post-filter."""

    name = "cccae"
    capabilities = frozenset({EMBEDDING, STREAMING})
    default_feature = "wav"
    uses_embedding = True
    default_alpha = 1.0


class AeDnnSystem(CccaeSystem):
    """M_AE (paper §4.2): the same pipeline with a plain autoencoder (α = 0)."""

    name = "ae-dnn"
    default_alpha = 0.0
    alpha_fixed = True


class MfccDnnSystem(DnnSystem):
    """M_MFCC (paper §4.2): MFCC-39 → regressor → post-filter (the former shipped default: its speed
    map is cross-fitted by default)."""

    name = "mfcc-dnn"
    default_feature = "mfcc"
    default_cross_fit = True


class FbankDnnSystem(DnnSystem):
    """FBank-27 → regressor → post-filter (paper §4.3's comparison features)."""

    name = "fbank-dnn"
    default_feature = "fbank"


class F0eDnnSystem(DnnSystem):
    """F0 + energy with Δ and ΔΔ → regressor → post-filter (paper §4.3)."""

    name = "f0e-dnn"
    default_feature = "f0e"


class WavDnnSystem(DnnSystem):
    """Raw 100-dim waveform frames straight into the regressor (paper Table 1's "waveform")."""

    name = "wav-dnn"
    default_feature = "wav"


__all__ = ["CccaeSystem", "AeDnnSystem", "MfccDnnSystem", "FbankDnnSystem", "F0eDnnSystem", "WavDnnSystem"]
